"""The thesis search's rules on constructed scores: combination, ordering, exclusion, refinement
(issue 33).  No audio is rendered: each rule is checked against its closed form."""

from __future__ import annotations

import dataclasses
import math

import pytest

from benchmarks.thesis.readings import (
    COARSE,
    EB_LIMIT_DB,
    TREND_LIMIT_DB,
    Reading,
    Score,
    _families,
    coarse_grid,
    combined,
    excluded_because,
    refine,
    score_cells,
)
from benchmarks.thesis.reference import ThesisRow


def _score(snr_i, pesq=math.nan, trend=0.0):
    return Score(snr_i, pesq, trend, 18, 0 if math.isnan(pesq) else 18)


def test_combined_adds_each_distance_in_units_of_its_target():
    # 2 dB SNR-I and 0.2 PESQ are one unit each; a search without PESQ ranks by SNR-I alone.
    assert combined(_score(3.0, 0.1)) == pytest.approx(3.0 / 2 + 0.1 / 0.2)
    assert combined(_score(3.0)) == pytest.approx(1.5)
    # The order it gives: 1 dB worse SNR-I is worth 0.1 better PESQ.
    assert combined(_score(2.0, 0.3)) == pytest.approx(combined(_score(3.0, 0.2)))


def test_score_cells_is_the_mean_absolute_distance_and_the_trend_difference():
    rows = [ThesisRow("7.1", "EB", "babble", 0.0, 13.0, 13.0, 1.6, 2.0, 0.4),
            ThesisRow("7.1", "EB", "babble", 25.0, 38.0, 13.5, 2.6, 3.0, 0.4)]
    s = score_cells({("EB", "babble", 0.0): (11.0, 2.5), ("EB", "babble", 25.0): (16.0, None)}, rows)
    # |11 - 13| and |16 - 13.5| -> 2.25; PESQ only where given: |2.5 - 2.0|; trend |(16 - 11) - 0.5| = 4.5
    assert (s.snr_i, s.pesq, s.trend, s.n_snr, s.n_pesq) == (pytest.approx(2.25), pytest.approx(0.5),
                                                           pytest.approx(4.5), 2, 1)


@pytest.mark.parametrize(("trend", "snr_i", "kept"), [
    (TREND_LIMIT_DB, EB_LIMIT_DB, True),             # at both limits: kept (the limits are "more than")
    (TREND_LIMIT_DB + 1e-9, 1.0, False),
    (0.0, EB_LIMIT_DB + 1e-9, False),
])
def test_exclusion_at_its_limits(trend, snr_i, kept):
    why = excluded_because(_score(snr_i, trend=trend))
    assert (why is None) == kept
    if not kept:
        assert ("trend" in why) == (trend > TREND_LIMIT_DB)


def test_coarse_grid_is_the_full_factorial_once_each():
    grid = coarse_grid()
    assert len(grid) == math.prod(len(v) for v in COARSE.values()) == 1152
    assert len(set(grid)) == len(grid)
    assert {r.fd_taps for r in grid} == set(COARSE["fd_taps"])


def test_refine_varies_the_two_continuous_unknowns_around_the_best():
    best = Reading(fd_taps=33, eq_fc_hz=150.0, adapt="slow", beta_max=0.2)
    fine = refine(best)
    assert {r.fd_taps for r in fine} == {25, 29, 33, 37, 41}
    assert {r.eq_fc_hz for r in fine} == {105.0, 127.5, 150.0, 180.0, 210.0}
    assert len(fine) == 25 and best in fine
    assert all(dataclasses.replace(r, fd_taps=33, eq_fc_hz=150.0) == best for r in fine)  # nothing else moves
    assert {r.fd_taps for r in refine(dataclasses.replace(best, fd_taps=5))} == {5, 9, 13}  # 1 and -3 taps dropped


def test_families_keep_each_familys_best_in_score_order_without_duplicates():
    # Three families (angle convention, adaptation, beta limit); the kept list is sorted by score.
    a1, a2 = Reading(adapt="slow", fd_taps=9), Reading(adapt="slow", fd_taps=17)
    b1 = Reading(adapt="free")
    c1 = Reading(adapt="gated", beta_max=0.5)
    c2 = Reading(adapt="gated", beta_max=0.2)  # another family, but the same cells as c1: a duplicate
    scored = {a1: _score(1.0), a2: _score(2.0), b1: _score(0.5), c1: _score(3.0), c2: _score(3.0)}
    kept = sorted(scored, key=lambda r: scored[r].snr_i)
    assert _families(scored, kept, 10) == [b1, a1, c1]
    assert _families(scored, kept, 2) == [b1, a1]
