"""``benchmarks.perf.calibration_jitter``'s decomposition of ``eb-robust``'s speech jitter per adapted quantity.

Oracle: :func:`benchmarks.perf.calibration_jitter.measure_condition`, which measures the jitter from the
enhancer's public replays (``Result.replay``), a path independent of the record swapping under test.
"""

from __future__ import annotations

import math

import pytest

from benchmarks.perf.calibration_jitter import measure_condition, swap_jitter
from benchmarks.run.sweep import load_sweep


@pytest.fixture(scope="module")
def condition():
    return next(c for c in load_sweep("phone").conditions() if c.noise == "wind" and c.snr_db == 15 and c.seed == 0)


def test_swap_of_everything_is_the_replayed_jitter(condition):
    """Swapping every adapted quantity is the ``s - n`` run itself: ``swap_jitter(...)["all"]`` equals the
    jitter of the two runs' replays (to 1e-6 dB), and the default ``eb-robust`` adapts all three quantities."""
    d = swap_jitter(condition, None, {})
    row = next(r for r in measure_condition(condition, None, names=("eb-robust",)) if r["system"] == "eb-robust")
    assert d["all"] == pytest.approx(row["jitter"], abs=1e-6)
    assert set(d) == {"all", "r_hat", "beta", "alpha"}


def test_a_quantity_not_adapted_is_absent_and_a_fixed_one_does_not_jitter(condition):
    """``calibrate=False``: no ``r_hat`` to swap; ``das_mix=False`` and beta frozen by its own gate everywhere (``adapt_gate_db=-60``: above the ratio's floor - 60 dB): the talker
    path is a fixed linear filter, identical in both runs (closed form: jitter -inf)."""
    d = swap_jitter(condition, None, {"calibrate": False, "das_mix": False, "adapt_gate_db": -60.0})
    assert set(d) == {"all", "beta"}
    assert d["all"] < -200 or math.isinf(d["all"])
