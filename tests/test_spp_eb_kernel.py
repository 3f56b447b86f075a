"""``eb-spp``'s compiled per-frame path against its numpy reference (slow reference: ``compiled = False``).

The kernels follow the reference term by term; sums run in another order (a loop here, pairwise numpy
sums and ``lfilter`` there) and ``e^{-j b k}`` is a recurrence, so the two agree to rounding: output,
replay, beta and the rear mic's response within 1e-10 relative.  The delay-and-sum weight alpha is a
ratio whose denominator vanishes where the differential and delay-and-sum paths coincide (above ~4
kHz, measured): there rounding moves alpha by up to ~1e-5 while its product with that vanishing
difference -- what reaches the weights and the output -- stays at rounding; alpha is held to 1e-4.
"""

from __future__ import annotations

import numpy as np
import pytest

import enhancers
from enhancers.beam.spp_eb import SppElkoBeamformer
from enhancers.testing import stream

FS = 16000


class _Reference(SppElkoBeamformer):
    compiled = False


def _pair(seed, seconds=6.0):
    """A correlated pair with a louder burst (the SPP moves) and a rear mic 1.5 dB off."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    x = 0.1 * rng.standard_normal((2, n))
    x[1] = 0.84 * (0.6 * x[1] + 0.6 * np.roll(x[0], 1))
    x[:, n // 3 : n // 2] *= 10.0
    return x


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("params", [{}, {"spp": "single"}, {"tau_cal_s": 1.0, "max_gain_db": 1.0}])
def test_compiled_path_equals_the_numpy_reference(params):
    x = _pair(0)
    a = enhancers.make("eb-spp", **params).process(x, FS)
    b = _Reference(**params).process(x, FS)
    assert _rel(a.output, b.output) <= 1e-10
    s = _pair(1)
    assert _rel(a.replay(s), b.replay(s)) <= 1e-10
    for key in ("beta", "rear_gain_db", "rear_phase_deg"):
        assert np.max(np.abs(a.trace[key] - b.trace[key])) <= 1e-10 * max(1.0, np.max(np.abs(b.trace[key])))
    assert np.max(np.abs(a.trace["alpha"] - b.trace["alpha"])) <= 1e-4


@pytest.mark.parametrize("block", [128, 97])
def test_compiled_streaming_equals_the_reference_batch(block):
    x = _pair(2, seconds=3.0)
    e = enhancers.make("eb-spp")
    ref = _Reference().process(x, FS).output
    assert _rel(stream(e, x, FS, block), ref) <= 1e-10


def test_without_a_calibration_average_both_paths_are_the_reference():
    x = _pair(3, seconds=3.0)
    a = enhancers.make("eb-spp", tau_cal_s=0.0).process(x, FS)
    b = _Reference(tau_cal_s=0.0).process(x, FS)
    assert _rel(a.output, b.output) <= 1e-10
