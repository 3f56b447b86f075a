"""Adaptive MVDR and SDW-MWF (enhancers.beam.mvdr): GEVD RTF, distortionless output, MWF closed forms.

Oracles: a far-field plane wave's RTF exp(-j 2 pi f d cos(theta) / c) (physical law); the MVDR's
distortionless constraint w^H h = 1, which makes the replayed speech equal the reference mic's
speech image through the same filter bank; the SDW-MWF's closed forms for mu = 0 (the MVDR),
mu = 1 (MVDR times the Wiener gain xi / (1 + xi)) and mu -> inf (Phi_vv^-1 Phi_xx e_ref / mu).
"""

from __future__ import annotations

import numpy as np
import pytest

from enhancers.beam.mvdr import (
    Mvdr,
    gevd_rtf,
    mvdr_weights,
    rank1_mwf_weights,
    sdw_mwf_weights,
    with_startup_prior,
)
from enhancers.beam.noise_stats import outer
from enhancers.beam.superdirective import diffuse_coherence
from enhancers.core.filterbank import FilterBank
from enhancers.core.registry import make
from enhancers.testing import stream

FS, C, D = 16000, 343.0, 0.0214


def _plane_wave(rng, n, az_deg):
    """``(2, n)``: white noise from ``az_deg`` (far field), mic 2 delayed by ``d cos(az) / c`` (exact, circular)."""
    f = np.fft.rfftfreq(n, 1.0 / FS)
    src = np.fft.rfft(rng.standard_normal(n))
    tau = D * np.cos(np.radians(az_deg)) / C
    return np.fft.irfft(np.stack([src, src * np.exp(-2j * np.pi * f * tau)]), n=n)


def _rtf(az_deg, n_fft=256):
    f = np.fft.rfftfreq(n_fft, 1.0 / FS)
    return np.stack([np.ones_like(f), np.exp(-2j * np.pi * f * D * np.cos(np.radians(az_deg)) / C)], axis=-1)


def test_gevd_rtf_is_exact_for_a_rank_one_source_in_white_noise(rng):
    h = _rtf(45.0)
    phi = rng.uniform(0.1, 10.0, h.shape[0])
    Phi_vv = np.broadcast_to(0.3 * np.eye(2, dtype=complex), (h.shape[0], 2, 2))
    est, lam = gevd_rtf(phi[:, None, None] * outer(h) + Phi_vv, Phi_vv)
    np.testing.assert_allclose(est, h, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lam - 1.0, phi * 2 / 0.3, rtol=1e-10)  # output SNR phi h^H Phi_vv^-1 h


def test_gevd_rtf_of_a_far_field_source_in_spatially_white_noise_from_sample_covariances(rng):
    n = FS * 20
    s = _plane_wave(rng, n, 45.0)
    v = 0.1 * rng.standard_normal((2, n))  # spatially white, -20 dB
    fb = FilterBank()
    S, V = (np.moveaxis(fb.analyze(x), 0, -1) for x in (s, v))
    Phi_vv = outer(V).mean(axis=0)
    Phi_yy = outer(S + V).mean(axis=0)
    est, _ = gevd_rtf(Phi_yy, Phi_vv)
    # 2500 frames per bin (~1250 independent) at 20 dB: error ~ 1/sqrt(1250 x 100) ~ 0.003 per bin, and the
    # 16 ms window's delay approximation; DC and Nyquist are real-valued bins
    np.testing.assert_allclose(est[2:-2], _rtf(45.0)[2:-2], rtol=0, atol=0.02)


def _speech_error_db(w, s):
    """Replayed speech (fixed weights per bin, through ``Mvdr._apply``) against mic 0's speech image through
    the same filter bank: error power re speech, dB."""
    fb = FilterBank()
    S = fb.analyze(s)
    record = {"weights": np.broadcast_to(w, (S.shape[1],) + w.shape)}
    out = fb.synthesize(Mvdr()._apply(record, S, FS), s.shape[-1])[0]
    ref = fb.synthesize(S[:1], s.shape[-1])[0]
    return 10 * np.log10(np.sum((out - ref) ** 2) / np.sum(ref**2))


def test_mvdr_output_speech_is_the_reference_mics_speech_image(rng):
    # Talker at broadside with the rear mic 1 dB low: the RTF [1, 10^(-1/20)] is exactly a per-bin product
    # in the STFT.  (A fractional delay is a per-bin phase only approximately in 16 ms frames: at 45 deg
    # the true-RTF MVDR with Phi_vv = I reaches -33 dB, the window's error, not the beamformer's.)
    n, g = FS * 4, 10 ** (-1 / 20)
    s = _plane_wave(rng, n, 90.0) * np.array([[1.0], [g]])
    v = _plane_wave(rng, n, 150.0) + 0.1 * rng.standard_normal((2, n))  # a rear point noise and white noise
    V = np.moveaxis(FilterBank().analyze(v), 0, -1)
    Phi_vv = outer(V).mean(axis=0)  # oracle noise covariance
    h = np.broadcast_to(np.array([1.0, g], dtype=complex), (Phi_vv.shape[0], 2))
    assert _speech_error_db(mvdr_weights(h, Phi_vv), s) <= -40.0
    # the check has teeth: a fixed filter that ignores the rear mic's 1 dB (RTF [1, 1]) distorts the speech
    wrong = mvdr_weights(_rtf(90.0), Phi_vv)
    assert _speech_error_db(wrong, s) > -40.0


def _rank1_case(rng, k=50):
    h = np.stack([np.ones(k), np.exp(1j * rng.uniform(-3, 3, k)) * rng.uniform(0.5, 1.5, k)], axis=-1)
    A = rng.standard_normal((k, 2, 2)) + 1j * rng.standard_normal((k, 2, 2))
    Phi_vv = A @ np.conj(np.swapaxes(A, -1, -2)) + 0.1 * np.eye(2)
    phi = rng.uniform(0.1, 5.0, k)
    return h, Phi_vv, phi[:, None, None] * outer(h), phi


def test_sdw_mwf_closed_forms_for_mu_0_1_and_large(rng):
    h, Phi_vv, Phi_xx, phi = _rank1_case(rng)
    w_mvdr = mvdr_weights(h, Phi_vv)
    xi = phi * np.real(np.einsum("ki,kij,kj->k", np.conj(h), np.linalg.inv(Phi_vv), h))
    np.testing.assert_allclose(sdw_mwf_weights(Phi_vv, Phi_xx, 0.0), w_mvdr, rtol=1e-10)
    np.testing.assert_allclose(sdw_mwf_weights(Phi_vv, Phi_xx, 1.0), w_mvdr * (xi / (1 + xi))[:, None], rtol=1e-10)
    big = 1e6
    limit = np.einsum("kij,kj->ki", np.linalg.inv(Phi_vv), Phi_xx[:, :, 0]) / big
    np.testing.assert_allclose(sdw_mwf_weights(Phi_vv, Phi_xx, big), limit, rtol=1e-4)


@pytest.mark.parametrize("mu", [0.0, 1.0, 30.0])
def test_the_enhancers_rank1_weights_equal_the_general_formula(rng, mu):
    h, Phi_vv, Phi_xx, _ = _rank1_case(rng)
    w = rank1_mwf_weights(Phi_xx + Phi_vv, Phi_vv, mu, loading=0.0)
    # rtol 1e-4: the GEVD's own guard loads Phi_vv by 1e-6 of its mean diagonal (enhancers.beam.mvdr)
    np.testing.assert_allclose(w, sdw_mwf_weights(Phi_vv, Phi_xx, mu), rtol=1e-4, atol=1e-12)


@pytest.mark.parametrize("name", ["mvdr", "mwf", "mvdr@1"])
def test_streaming_equals_batch(rng, name):
    e = make(name)
    x = 0.1 * _plane_wave(rng, FS // 2, 45.0) + 0.05 * rng.standard_normal((2, FS // 2))
    y = e.process(x, FS).output
    for block in (1, e.hop, 97):
        np.testing.assert_allclose(stream(e, x, FS, block), y, rtol=0, atol=1e-10)


def test_replay_of_the_mixture_is_the_output_and_weights_are_recorded(rng):
    x = 0.1 * _plane_wave(rng, FS, 45.0) + 0.05 * rng.standard_normal((2, FS))
    r = make("mvdr-ss").process(x, FS)
    np.testing.assert_allclose(r.replay(x), r.output, rtol=0, atol=1e-9)
    assert r.trace["mvdr.weights"].shape == (FS // 128, 129, 2)


def test_startup_prior_gives_the_unfilled_mass_to_the_diffuse_field(rng):
    # Oracle: the spherically isotropic field's coherence sinc(2 f d / c) (physical law), at the
    # estimate's own level; N = 1 leaves the estimate, N = 0 is the prior alone.
    e = make("mvdr")
    shape = e._prior_shape(129, FS)
    f = np.arange(129) * FS / 256
    np.testing.assert_allclose(shape[:, 0, 1].real, diffuse_coherence(f, spacing_m=D, c_mps=C), rtol=0, atol=1e-12)
    V = outer(rng.standard_normal((3, 129, 2)) + 1j * rng.standard_normal((3, 129, 2)))
    level = 0.5 * np.real(V[..., 0, 0] + V[..., 1, 1])
    np.testing.assert_allclose(with_startup_prior(V, np.zeros((3, 129)), shape), level[..., None, None] * shape,
                               rtol=1e-12)
    np.testing.assert_allclose(with_startup_prior(V, np.ones((3, 129)), shape), V, rtol=1e-12)
    assert with_startup_prior(V, np.zeros((3, 129)), None) is V
    assert make("mvdr", startup_prior="white")._prior_shape(129, FS)[5].tolist() == np.eye(2).tolist()


def test_version_1_is_kept_and_differs_from_version_2(rng):
    x = 0.1 * _plane_wave(rng, FS, 45.0) + 0.05 * rng.standard_normal((2, FS))
    old = make("mvdr", startup_prior="none", noisy_weight="every").process(x, FS).output
    np.testing.assert_array_equal(make("mvdr@1").process(x, FS).output, old)
    assert np.max(np.abs(make("mvdr").process(x, FS).output - old)) > 1e-3 * np.max(np.abs(old))
    assert make("mvdr-ss@1").stages[0] == ("mvdr", "mvdr@1") and make("mwf@1").params.startup_prior == "none"


def test_the_enhancer_applies_the_startup_prior_and_it_fades(rng):
    # A talker (white, 45 deg) over a point noise (150 deg) and sensor noise: the RTF is defined in every
    # bin.  The prior's weight is the noise average's unfilled mass, so the weights differ from the
    # prior-free ones at the start (median relative difference over bins 0.63-0.98 in the first 10
    # frames) and agree once the average has filled (0.011 over the last 50 frames of 4 s).
    n = 4 * FS
    x = _plane_wave(rng, n, 45.0) + 0.3 * _plane_wave(rng, n, 150.0) + 0.03 * rng.standard_normal((2, n))
    w = make("mvdr").process(x, FS).trace["weights"]
    w0 = make("mvdr", startup_prior="none").process(x, FS).trace["weights"]
    d = np.linalg.norm(w - w0, axis=-1) / np.linalg.norm(w0, axis=-1)
    assert np.all(np.median(d[:10], axis=-1) > 0.5)
    assert np.median(d[-50:]) < 0.03
