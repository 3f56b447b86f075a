"""Issue 33: the report's display rules at their boundaries and with their signs.

Kept apart from the report's own test files (another change is under way there); each test
names its oracle.
"""

from __future__ import annotations

import math

import pytest
from scipy import stats

from benchmarks.report.tables import (
    MIN_T_SEEDS,
    clip_interval,
    error_bars,
    interval_clipped,
    metric_range,
    seed_interval,
    stat_cell,
)
from benchmarks.report.verdicts import _verdict_record, verdict


def _t_interval(values):
    """Outside oracle: scipy's Student-t interval of the mean."""
    m = sum(values) / len(values)
    half = stats.t.ppf(0.975, len(values) - 1) * stats.tstd(values) / math.sqrt(len(values))
    return m, m - half, m + half


def test_small_n_switches_from_the_seeds_range_to_the_t_interval_at_min_t_seeds():
    below = [1.0, 2.0, 2.5, 6.0][: MIN_T_SEEDS - 1]
    at = [1.0, 2.0, 2.5, 6.0, 3.0][:MIN_T_SEEDS]
    assert MIN_T_SEEDS == 5
    assert seed_interval(below, "snr_i_db") == (pytest.approx(sum(below) / 4), 1.0, 6.0)
    assert seed_interval(at, "snr_i_db") == pytest.approx(_t_interval(at), rel=1e-9)
    rec4 = {"x_db": 2.875, "x_db_n": 4, "x_db_min": 1.0, "x_db_max": 6.0}
    rec5 = {"x_db": 2.9, "x_db_n": 5, "x_db_ci95": 2.0}
    assert stat_cell(rec4, "x_db") == "2.9 (1.0 … 6.0)"
    assert stat_cell(rec5, "x_db") == "2.9 ± 2.0"
    assert stat_cell({"x_db": 2.9, "x_db_n": 1}, "x_db") == "2.9"


def test_error_bars_are_the_distances_below_and_above_the_mean():
    # Seeds 1, 2, 6 (mean 3): 2 below, 3 above -- magnitudes, lower first, never negative.
    rec = {"x": 3.0, "x_n": 3, "x_min": 1.0, "x_max": 6.0}
    assert error_bars([rec], "x") == [[2.0], [3.0]]


@pytest.mark.parametrize(("field", "lo", "hi", "want"), [
    ("pesq_wb_out", 3.0, 5.0, (3.0, 4.64)),
    ("pesq_nb_raw_out", -1.0, 2.0, (-0.5, 2.0)),
    ("stoi_out", 0.5, 1.2, (0.5, 1.0)),
    ("stoi_i", -1.5, 0.3, (-1.0, 0.3)),                 # an improvement spans the width either way
    ("pesq_wb_i", -4.0, 4.0, (-3.64, 3.64)),
    ("snr_i_db", -80.0, 90.0, (-80.0, 90.0)),           # dB: unbounded
])
def test_intervals_are_clipped_to_their_metrics_range(field, lo, hi, want):
    assert clip_interval(field, lo, hi) == pytest.approx(want)


def test_a_clipped_interval_is_marked_and_an_unclipped_one_is_not():
    assert metric_range("estoi_out") == (0.0, 1.0)
    assert interval_clipped([0.99, 0.2, 0.99, 0.99, 0.99], "stoi_out")
    assert not interval_clipped([0.5, 0.52, 0.49, 0.51, 0.5], "stoi_out")
    cell = stat_cell({"stoi_out": 0.9, "stoi_out_n": 6, "stoi_out_ci95": 0.2}, "stoi_out")
    assert cell == "0.90 [0.70, 1.00]*"


@pytest.mark.parametrize(("lo", "hi", "want"), [
    (0.0, 1.0, "not resolved"),      # an interval that touches 0 does not exclude "no difference"
    (-1.0, 0.0, "not resolved"),
    (1e-9, 1.0, "better"),
    (-1.0, -1e-9, "worse"),
    (None, 1.0, "not resolved"),
])
def test_the_verdict_at_an_interval_edge(lo, hi, want):
    assert verdict(lo, hi) == want


def test_a_verdict_records_system_minus_baseline_with_its_min_and_max():
    # Per seed the system beats the baseline by +1, -0.5, +2 dB: min -0.5, max +2, mean 5/6.
    d = {0: 1.0, 1: -0.5, 2: 2.0}
    pairs = [({"seed": s, "x": 10.0 + s}, {"seed": s, "x": 10.0 + s + v}) for s, v in d.items()]
    rec = _verdict_record(pairs, "x", "babble", "ss", "eb")
    assert (rec["min_diff"], rec["max_diff"]) == (-0.5, 2.0)
    assert rec["mean_diff"] == pytest.approx(5 / 6)
    m, lo, hi = _t_interval(list(d.values()))
    assert (rec["ci_low"], rec["ci_high"]) == (pytest.approx(lo), pytest.approx(hi))
    assert rec["verdict"] == "not resolved" and rec["n"] == 3


def test_the_ranking_counts_its_seeds_per_metric():
    # Metric x on seeds 0-4, metric y only on seeds 0-2 (e.g. DNSMOS missing later): each
    # pairwise test and each interval is over that metric's own seeds (n 5 and 3).
    from benchmarks.report.ranking import pairwise_tests

    rows = []
    for s in range(5):
        for e, off in (("a", 0.0), ("b", 1.0)):
            rows.append({"condition_id": f"c{s}", "seed": s, "noise": "w", "enhancer": e, "pesq_wb_out": 2.0 + off + 0.1 * s,
                         "estoi_out": (0.5 + 0.1 * off + 0.01 * s) if s < 3 else None})
    tests = {t["metric"]: t for m in ("pesq_wb_out", "estoi_out") for t in pairwise_tests(rows, ["b", "a"], m)}
    assert tests["pesq_wb_out"]["n"] == 5 and tests["estoi_out"]["n"] == 3
    assert tests["pesq_wb_out"]["mean_diff"] == pytest.approx(1.0)
    assert tests["estoi_out"]["mean_diff"] == pytest.approx(0.1)
