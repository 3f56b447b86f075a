"""Diffuse, incoherent and sensor noise (algorithms.md section 4).

Oracle for the diffuse field: the spherically isotropic coherence sinc(2 f d / c)
(Habets & Gannot 2007), measured with Welch's method (real part of the complex coherence,
scipy.signal.csd / welch).  Tolerance 0.05 mean absolute deviation over 0..fs/2: with 10 s
at 16 kHz and 256-sample segments (~1250 averages) the estimator's standard deviation is
about 0.02, so a correct generator sits near 0.01-0.02.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from scenesim.errors import ParameterError
from scenesim.scene.geometry import MicPair
from scenesim.scene.noise_fields import (
    diffuse_noise,
    incoherent_noise,
    independent_channels,
    sensor_noise,
)

FS = 16000
C = 343.0


def real_coherence(x, nperseg=256):
    f, pxy = sps.csd(x[0], x[1], fs=FS, nperseg=nperseg)
    _, pxx = sps.welch(x[0], fs=FS, nperseg=nperseg)
    _, pyy = sps.welch(x[1], fs=FS, nperseg=nperseg)
    return f, np.real(pxy) / np.sqrt(pxx * pyy)


@pytest.mark.parametrize("pair_or_spacing", [MicPair(), 0.2])
def test_diffuse_coherence_matches_sinc(pair_or_spacing):
    x = diffuse_noise(10 * FS, pair_or_spacing, fs=FS, rng=np.random.default_rng(1))
    d = pair_or_spacing.spacing_m if isinstance(pair_or_spacing, MicPair) else pair_or_spacing
    f, coh = real_coherence(x)
    target = np.sinc(2 * f * d / C)
    assert np.mean(np.abs(coh - target)) < 0.05
    if d == 0.2:  # the wide pair really oscillates: the test would catch a constant coherence
        assert target.min() < -0.2


def test_diffuse_keeps_unit_power_and_the_source_spectrum(rng):
    # Eigen mixing preserves each bin's power (E|X_i|^2 = E|N|^2): unit-variance white in,
    # unit variance out (5 % tolerance: ~14 sigma of the estimator, whose std is
    # sqrt(2 / N) = 0.35 % at N = 160000 samples).
    x = diffuse_noise(10 * FS, 0.0214, fs=FS, rng=rng)
    np.testing.assert_allclose(np.var(x, axis=1), 1.0, rtol=0.05)
    # A coloured mono source: channel spectra follow it (Welch PSD ratio within 1 dB
    # averaged over 100 Hz..7 kHz) and the coherence is still the sinc.
    src = sps.lfilter([1.0], [1.0, -0.9], rng.standard_normal(20 * FS))
    y = diffuse_noise(10 * FS, 0.2, fs=FS, source=src)
    f, p_src = sps.welch(src[: 10 * FS], fs=FS, nperseg=256)
    _, p_out = sps.welch(y, fs=FS, nperseg=256, axis=1)
    band = (f > 100) & (f < 7000)
    ratio_db = 10 * np.log10(p_out[:, band] / p_src[band])
    assert np.all(np.abs(np.mean(ratio_db, axis=1)) < 1.0)
    f, coh = real_coherence(y)
    assert np.mean(np.abs(coh - np.sinc(2 * f * 0.2 / C))) < 0.05


def test_incoherent_noise_has_zero_coherence(rng):
    # Oracle: independence -> coherence 0; same 0.05 estimator tolerance as above.
    x = incoherent_noise(10 * FS, rng=rng)
    _, coh = real_coherence(x)
    assert np.mean(np.abs(coh)) < 0.05
    src = rng.standard_normal(10 * FS)
    y = incoherent_noise(5 * FS, source=src)
    np.testing.assert_array_equal(y[0], src[: 5 * FS])  # channel 0 is the recording itself
    np.testing.assert_array_equal(y[1], src[5 * FS :])  # channel 1 the disjoint second half
    _, coh = real_coherence(y)
    assert np.mean(np.abs(coh)) < 0.05


def test_two_channel_source_is_used_as_given(rng):
    src = rng.standard_normal((2, 1000))
    np.testing.assert_array_equal(independent_channels(800, source=src), src[:, :800])


def test_sensor_noise_level(rng):
    # Oracle: power = 10^(level/10); tolerance 0.1 dB (estimator std 0.015 dB at 160000 samples).
    x = sensor_noise(10 * FS, level_db=-40.0, rng=rng)
    assert x.shape == (2, 10 * FS)
    np.testing.assert_allclose(10 * np.log10(np.mean(x**2, axis=1)), -40.0, atol=0.1)


def test_deterministic_for_a_seed():
    a = diffuse_noise(1000, 0.0214, fs=FS, rng=np.random.default_rng(5))
    b = diffuse_noise(1000, 0.0214, fs=FS, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)


def test_bad_inputs_raise(rng):
    with pytest.raises(ParameterError, match="source"):
        diffuse_noise(1000, 0.0214, fs=FS, source=np.ones(999))
    with pytest.raises(ParameterError, match="source"):
        incoherent_noise(100, source=np.ones((3, 200)))
    with pytest.raises(ParameterError, match="rng"):
        diffuse_noise(1000, 0.0214, fs=FS, rng=None)
    with pytest.raises(ParameterError, match="pair_or_spacing"):
        diffuse_noise(1000, -0.1, fs=FS, rng=rng)
    with pytest.raises(ParameterError, match="n_samples"):
        sensor_noise(0, level_db=-40.0, rng=rng)
    with pytest.raises(ParameterError, match="level_db"):
        sensor_noise(10, level_db=float("inf"), rng=rng)
