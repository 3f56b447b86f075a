"""``benchmarks.studies.ss_gain_candidates`` (ss's gain on ``eb-robust``'s replayed parts) against the chain itself.

Oracle: :func:`benchmarks.studies.calibration_jitter.measure_condition` on ``eb-robust-ss`` (the registered chain,
run on both Hagerman mixtures and replayed through its composed stages), a path that shares neither the
stage-by-stage replay nor the ``s - n = F s - F n`` shortcut under test.
"""

from __future__ import annotations

import pytest

from benchmarks.run.sweep import load_sweep
from benchmarks.studies.calibration_jitter import measure_condition
from benchmarks.studies.ss_gain_candidates import CANDIDATES, FIXED_FRONT_END, measure


@pytest.fixture(scope="module")
def condition():
    return next(c for c in load_sweep("phone").conditions() if c.noise == "babble" and c.snr_db == 15 and c.seed == 0)


def test_candidates_match_the_chain(condition):
    """The averaged gain's jitter (fixed front end) and the default's and averaged gain's replay SNR-I
    (default front end) equal the chain's, to 1e-6 dB."""
    name = "averaged-2-2-0.55"
    rows = {r["candidate"]: r for r in measure(condition, None, ["default", name], pesq=False)}

    def chain(overrides, ss):
        return next(r for r in measure_condition(condition, None, ("eb-robust-ss",), overrides=overrides, ss=ss))

    fixed = chain(FIXED_FRONT_END, CANDIDATES[name])
    assert rows[name]["jitter"] == pytest.approx(fixed["jitter"], abs=1e-6)
    assert rows[name]["snri"] == pytest.approx(chain(None, CANDIDATES[name])["replay"], abs=1e-6)
    assert rows["default"]["snri"] == pytest.approx(chain(None, None)["replay"], abs=1e-6)
    assert rows[name]["jitter"] < rows["default"]["jitter"] - 3.0  # the averaged gain does something here
