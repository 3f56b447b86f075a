"""``eb-spp``'s compiled per-frame path against its numpy reference (slow reference: ``compiled = False``).

The kernels follow the reference term by term; sums run in another order (a loop here, pairwise numpy
sums and ``lfilter`` there) and ``e^{-j b k}`` is a recurrence, so the two agree to rounding: output,
replay, beta and the rear mic's response within 1e-10 relative.  The delay-and-sum weight alpha is a
ratio whose denominator vanishes where the differential and delay-and-sum paths coincide (above ~4
kHz, measured): there rounding moves alpha by up to ~1e-5 while its product with that vanishing
difference -- what reaches the weights and the output -- stays at rounding; alpha is held to 1e-4.
"""

from __future__ import annotations

import math

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


# -- each kernel against its numpy reference on random inputs (not only states a recording reaches)

def _random_stats(rng, F=40, K=129):
    """Noise averages of the frames (``prev (K, 2, 2)``, ``vv (F, K, 2, 2)``: Hermitian, positive
    semi-definite, levels spread over 60 dB) and their normalisers ``n_prev (K,)``, ``nv (F, K)``
    in (0, 1)."""
    y = rng.standard_normal((F + 1, K, 2, 3)) + 1j * rng.standard_normal((F + 1, K, 2, 3))
    y *= 10.0 ** rng.uniform(-3.0, 0.0, (F + 1, K, 1, 1))
    cov = np.einsum("fkit,fkjt->fkij", y, np.conj(y))
    n = rng.uniform(0.0, 1.0, (F + 1, K))
    return cov[0], cov[1:], n[0], n[1:]


def _reference_prior(stats):
    """``Phi (F, K, 2, 2)`` with the start-up prior by the numpy reference (frame l from l - 1)."""
    prev, vv, n_prev, nv = stats
    Phi = np.concatenate([prev[None], vv[:-1]])
    N = np.concatenate([n_prev[None], nv[:-1]])
    return _Reference()._with_prior(Phi, N, FS)


def test_prior_and_calibration_kernel_equals_the_reference_on_random_covariances():
    from enhancers.kernels.spp_eb import prior_and_calibration

    rng = np.random.default_rng(10)
    stats = _random_stats(rng)
    ref_e = _Reference()
    Phi = _reference_prior(stats)
    avg = np.stack([Phi[..., 0, 0], Phi[..., 1, 1], Phi[..., 1, 0]], axis=1)
    C0 = rng.standard_normal((3, 129)) + 1j * rng.standard_normal((3, 129))
    want = ref_e._calibration_average(avg, C0, 0.7, FS)
    lam = math.exp(-int(ref_e.params.hop) / FS / float(ref_e.params.tau_cal_s))
    got = prior_and_calibration(*stats, ref_e._coherence(FS), lam, C0, 0.7)
    for g, w in zip(got[:2], want[:2]):
        np.testing.assert_allclose(g, w, rtol=1e-10, atol=1e-10 * np.max(np.abs(w)))
    assert got[2] == pytest.approx(want[2], rel=1e-12)


def test_closed_form_kernel_equals_the_reference_on_random_covariances():
    from enhancers.kernels.spp_eb import closed_form_frames

    rng = np.random.default_rng(11)
    stats = _random_stats(rng)
    F, K = stats[3].shape
    inv = 10.0 ** rng.uniform(-0.3, 0.3, (F, K)) * np.exp(1j * rng.uniform(-0.5, 0.5, (F, K)))
    X = rng.standard_normal((2, F, K)) + 1j * rng.standard_normal((2, F, K))
    ref_e = _Reference()
    want = ref_e._weights(_reference_prior(stats), inv, X, FS)
    e, G, look, _, _ = ref_e._constants(FS)
    got = closed_form_frames(*stats, ref_e._coherence(FS), inv, e, G.astype(complex), look, X,
                             0.0, 0.5)
    for g, w in zip(got[:3], want[:3]):  # Y, w_raw, beta
        np.testing.assert_allclose(g, w, rtol=1e-10, atol=1e-10 * np.max(np.abs(w)))
    assert 0.0 < np.mean((want[2] > 0) & (want[2] < 1)) < 1.0  # clipped and interior betas occur
    np.testing.assert_allclose(got[3], want[3], rtol=0, atol=1e-4)  # alpha: module docstring


@pytest.mark.parametrize("phase_leak", [1.0, 0.9])
def test_estimate_kernel_equals_estimate_from_averages_with_clips_and_held_phases(phase_leak):
    """Random averages whose gains, phases and slopes reach the clips and whose coherence falls
    below the hold threshold in about a third of the cells (a phase held from ``prev_phase`` and
    from rows before)."""
    from enhancers.beam.mic_calibration import estimate_from_averages
    from enhancers.kernels.spp_eb import estimate_frames

    rng = np.random.default_rng(12)
    F, K = 30, 129
    s11 = 10.0 ** rng.uniform(-2, 2, (F, K))
    s22 = s11 * 10.0 ** rng.uniform(-1.2, 1.2, (F, K))  # +-12 dB: beyond the 6 dB clip
    coh = rng.uniform(0.0, 1.0, (F, K))
    phase = rng.uniform(-1.2, 1.2, (F, K)) + rng.uniform(-0.2, 0.2, (F, 1)) * np.arange(K)
    s21 = coh * np.sqrt(s11 * s22) * np.exp(1j * phase)
    avg = np.stack([s11, s22, s21], axis=1).astype(complex)
    prev = rng.uniform(-0.5, 0.5, K)
    kw = {"band": slice(8, 65), "max_slope": 0.05, "smooth_frac": 0.06, "max_gain_db": 6.0,
          "max_phase_deg": 30.0}
    want = estimate_from_averages(avg, smooth_bins=1, min_coherence=0.3, prev_phase=prev,
                                  phase_leak=phase_leak, **kw)
    half = np.maximum(1, np.round(kw["smooth_frac"] * np.arange(K)).astype(np.int64))
    got = estimate_frames(avg, 8, 65, kw["max_slope"], half, 6.0, math.radians(30.0), 0.3, prev,
                          phase_leak)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=0)
    gain = np.abs(want)
    assert np.any(np.isclose(gain, 10 ** (6 / 20))) and np.any(np.isclose(gain, 10 ** (-6 / 20)))
    assert np.any(np.isclose(np.abs(np.angle(want)), math.radians(30.0)))
    unheld = estimate_from_averages(avg, smooth_bins=1, **kw)
    held = ~np.isclose(want, unheld, rtol=1e-12, atol=0)
    assert 0.1 < held.mean() < 0.9 and held[0].any()  # held, from prev_phase in the first row too
