"""``eb-spp``: the differential beamformer whose calibration, beta and DAS weight come from the noise covariance.

Oracles: closed forms of a first-order pair (a broadside plane wave is nulled by the dipole, beta = 1, and a
rear-endfire one by the cardioid, beta = 0, at every frequency: algorithms.md section 5); a brute-force
minimisation of the output noise power over the DAS weight (slow reference); the known rear-mic mismatch
of a simulated diffuse field (the calibration must find it); the start-up priors' closed forms (the unfilled
mass of each average given to the diffuse-field model).
"""

from __future__ import annotations

import numpy as np
import pytest

import enhancers
from enhancers.beam.spp_eb import closed_form_weights
from enhancers.core.stft_stage import bin_omega

FS = 16000
T = 0.0214 / 343.0 * FS  # inter-mic delay, samples
OMEGA = bin_omega(256)[1:-1]  # leave out DC and Nyquist, where sin(wT) = 0
E = np.exp(-1j * OMEGA * T)


def _rank1(d):
    return d[..., :, None] * np.conj(d[..., None, :])


@pytest.mark.parametrize(("d", "beta"), [
    (np.stack([np.ones_like(E), np.ones_like(E)], axis=-1), 1.0),  # broadside: the dipole nulls it
    (np.stack([E, np.ones_like(E)], axis=-1), 0.0),                 # rear endfire: the cardioid does
])
def test_beta_nulls_a_plane_wave_the_first_order_pattern_can_null(d, beta):
    b, _, w = closed_form_weights(_rank1(d), E, np.ones_like(E), np.ones(E.shape), das_mix=False)
    np.testing.assert_allclose(b, beta, atol=1e-7)  # the regulariser biases by <= 1e-12 x power / E|cB|^2
    residual = np.abs(np.einsum("ki,ki->k", w, d)) ** 2 / np.sum(np.abs(w) ** 2, axis=-1)
    assert residual.max() < 1e-18  # the noise output is zero to rounding


def test_das_weight_minimises_the_output_noise_power():
    """Against a grid search of E|Y|^2 over alpha in [0, 1] (slow reference), for a mix of diffuse and
    spatially white noise: the closed form sits at the grid's minimum within its spacing."""
    sinc = np.sinc(2 * OMEGA / (2 * np.pi) * FS * 0.0214 / 343.0)
    Phi = np.zeros((OMEGA.size, 2, 2), dtype=complex)
    Phi[:, 0, 0] = Phi[:, 1, 1] = 1.0 + 0.3
    Phi[:, 0, 1] = Phi[:, 1, 0] = sinc
    G = 1.0 / np.abs(2 * np.sin(OMEGA * T)) * -1j
    look = np.ones(OMEGA.size)
    beta, alpha, w = closed_form_weights(Phi, E, G, look)
    grid = np.linspace(0.0, 1.0, 2001)
    a = np.stack([np.ones_like(E), -E], axis=-1)
    b = np.stack([-E, np.ones_like(E)], axis=-1)
    d = G[:, None] * (a - beta[:, None] * b)
    s = 0.5 * look[:, None] * np.stack([E, np.ones_like(E)], axis=-1)
    ws = d[None] - grid[:, None, None] * (d - s)[None]
    power = np.einsum("gki,kij,gkj->gk", ws, Phi, np.conj(ws)).real
    best = grid[np.argmin(power, axis=0)]
    np.testing.assert_allclose(alpha, best, atol=1e-3)
    assert np.all((alpha >= 0) & (alpha <= 1)) and alpha.max() > 0.5  # DAS wins where white noise dominates


def _diffuse_pair(n, rng, *, gain_db, phase_deg):
    """Two mics in a spherically isotropic field (per-bin Cholesky of the sinc coherence), the rear one
    with a complex response ``10^(gain/20) e^{j phase}`` applied in the STFT domain's sense (per rfft bin)."""
    N = 2 ** int(np.ceil(np.log2(n)))
    f = np.fft.rfftfreq(N, 1 / FS)
    coh = np.sinc(2 * f * 0.0214 / 343.0)
    z = rng.standard_normal((2, f.size)) + 1j * rng.standard_normal((2, f.size))
    x1 = z[0]
    x2 = coh * z[0] + np.sqrt(np.maximum(1 - coh**2, 0)) * z[1]
    x2 = x2 * 10 ** (gain_db / 20) * np.exp(1j * np.radians(phase_deg))
    return np.fft.irfft(np.stack([x1, x2]), N)[:, :n]


@pytest.mark.parametrize("spp", ["multi", "mean"])
@pytest.mark.parametrize("seed", [1, 4])
def test_calibration_finds_the_rear_mics_mismatch_in_diffuse_noise(seed, spp):
    """24 s of diffuse noise (six calibration time constants: the prior's weight is e^-6), no talker, rear mic
    2 dB / 15 deg off: the estimate at the end over 300 Hz-3 kHz; no calibration would be 2 dB / 15 deg off
    everywhere.  With the SPPs whose weights scale both mics' noise alike, the multichannel one and the
    tracker on the pair's mean periodogram (the reference-mic SPP weights by the front mic's power alone
    and biases the gain by 0.1-0.16 dB, worst bin 0.42 dB: module docstring); measured worst / median gain
    error 0.14 / 0.04 dB (multi), 0.18 / 0.09 dB (mean)."""
    x = _diffuse_pair(24 * FS, np.random.default_rng(seed), gain_db=2.0, phase_deg=15.0)
    res = enhancers.make("eb-spp", spp=spp).process(x, FS)
    f = np.arange(129) * FS / 256
    band = (f >= 300) & (f <= 3000)
    gain = np.abs(res.trace["rear_gain_db"][-1, band] - 2.0)
    phase = np.abs(res.trace["rear_phase_deg"][-1, band] - 15.0)
    assert gain.max() < 0.4 and np.median(gain) < 0.1
    assert phase.max() < 6.0 and np.median(phase) < 3.0


def test_a_broadside_noise_is_nulled_through_a_mismatched_rear_mic():
    """A broadside plane wave (both mics in phase) through a rear mic 1 dB / 5 deg off: once calibrated,
    the dipole cancels it; the last 8 s of 24 s must be attenuated by >= 25 dB re the front mic."""
    rng = np.random.default_rng(2)
    n = 24 * FS
    s = rng.standard_normal(n)
    spec = np.fft.rfft(s) * 10 ** (1 / 20) * np.exp(1j * np.radians(5.0))
    x = np.stack([s, np.fft.irfft(spec, n)])
    res = enhancers.make("eb-spp").process(x, FS)
    y = res.replay(x)[0]
    tail = slice(16 * FS, None)
    att = 10 * np.log10(np.mean(x[0, tail] ** 2) / np.mean(y[tail] ** 2))
    assert att >= 25.0, att


def test_the_calibration_prior_fills_exactly_the_averages_missing_mass():
    """Closed form of the calibration average for a constant input ``A`` per frame: the zero-started one-pole
    holds ``(1 - lam^(l+1)) A``, and the prior adds ``lam^(l+1) L (1, 1, gamma)`` with ``L`` the input's mean
    power and ``gamma`` the diffuse coherence ``sinc(2 f d / c)``; a diffuse input ``L (1, 1, gamma)`` is
    therefore returned unchanged from the first frame (no start-up transient). Tolerance 1e-12 relative."""
    e = enhancers.make("eb-spp", tau_cal_s=0.2)
    K = 129
    f = np.arange(K) * FS / 256
    gamma = np.sinc(2 * f * 0.0214 / 343.0)
    level = np.linspace(1.0, 3.0, K)
    diffuse = level[None] * np.stack([np.ones(K), np.ones(K), gamma]).astype(complex)
    out, _, _ = e._calibration_average(np.repeat(diffuse[None], 40, axis=0), np.zeros((3, K), complex), 1.0, FS)
    np.testing.assert_allclose(out, np.repeat(diffuse[None], 40, axis=0), rtol=1e-12, atol=0)
    A = np.stack([level, 2 * level, (0.5 + 0.3j) * level]).astype(complex)  # a mismatched pair
    out, _, m = e._calibration_average(np.repeat(A[None], 40, axis=0), np.zeros((3, K), complex), 1.0, FS)
    lam = np.exp(-128 / FS / 0.2)
    frac = lam ** np.arange(1, 41)
    prior = (1.5 * level)[None] * np.stack([np.ones(K), np.ones(K), gamma])
    expect = (1 - frac)[:, None, None] * A[None] + frac[:, None, None] * prior[None]
    np.testing.assert_allclose(out, expect, rtol=1e-12, atol=1e-12)
    assert m == pytest.approx(lam ** 40, rel=1e-12)


def test_the_noise_covariance_prior_fills_the_unfilled_mass_with_the_diffuse_model():
    """``N Phi + (1 - N) L Gamma`` in closed form: an empty average (``N = 0``) is the diffuse model at the
    level ``L = tr(Phi) / 2``, a full one (``N = 1``) is ``Phi`` itself, and halfway the mean of the two;
    for a diffuse ``Phi`` the closed-form beta of the filled matrix equals that of ``Phi`` (the prior moves
    nothing the data already says). Tolerance 1e-12."""
    e = enhancers.make("eb-spp")
    K = 129
    gamma = np.sinc(2 * np.arange(K) * FS / 256 * 0.0214 / 343.0)
    Phi = np.zeros((3, K, 2, 2), complex)
    Phi[..., 0, 0], Phi[..., 1, 1], Phi[..., 0, 1] = 2.0, 4.0, 1.0 + 1.0j
    Phi[..., 1, 0] = 1.0 - 1.0j
    N = np.array([0.0, 0.5, 1.0])[:, None] * np.ones((3, K))
    out = e._with_prior(Phi, N, FS)
    model = np.stack([np.stack([np.ones(K), gamma], -1), np.stack([gamma, np.ones(K)], -1)], -2) * 3.0
    np.testing.assert_allclose(out[0], model, atol=1e-12)
    np.testing.assert_allclose(out[1], 0.5 * (Phi[1] + model), atol=1e-12)
    np.testing.assert_allclose(out[2], Phi[2], atol=1e-12)
    diffuse = np.repeat(model[None], 3, axis=0)
    b_in = closed_form_weights(diffuse[:, 1:-1], E, np.ones_like(E), np.ones(E.shape))[0]
    b_out = closed_form_weights(e._with_prior(diffuse, N, FS)[:, 1:-1], E, np.ones_like(E), np.ones(E.shape))[0]
    np.testing.assert_allclose(b_out, b_in, atol=1e-12)
