"""Free-field plane waves and point sources (algorithms.md section 2).

Oracles: the plane-wave law tau_i = -(r_i . u)/c (inter-mic delay d cos(theta) cos(el) / c),
exact DFT-domain delays of band-limited periodic signals, and the 1/(4 pi r) law.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.scene.fractional_delay import DEFAULT_N_TAPS
from scenesim.scene.freefield import (
    plane_wave,
    plane_wave_delays,
    point_source,
    point_source_geometry,
)
from scenesim.scene.geometry import MicPair

FS = 16000
C = 343.0


def bandlimited_periodic(rng, n, n_tones=50, max_fraction=0.8):
    bins = rng.choice(np.arange(1, int(max_fraction * n / 2)), size=n_tones, replace=False)
    amps = rng.uniform(0.2, 1.0, n_tones)
    phases = rng.uniform(0, 2 * np.pi, n_tones)

    def at(delay):
        t = np.arange(n) - delay
        return np.sum(
            amps[:, None] * np.cos(2 * np.pi * bins[:, None] * t / n + phases[:, None]), axis=0
        )

    return at, float(amps.sum())


@pytest.mark.parametrize("az", [0.0, 45.0, 90.0, 135.0, 180.0, 270.0, 313.0])
def test_inter_mic_delay_is_d_cos_theta_over_c(az):
    # Oracle: plane-wave law; rear minus front delay = d cos(az) / c (tolerance 1e-12 samples).
    pair = MicPair(spacing_m=0.0214)
    d = plane_wave_delays(pair, azimuth_deg=az, fs=FS, c=C)
    np.testing.assert_allclose(d[1] - d[0], FS * 0.0214 * np.cos(np.deg2rad(az)) / C, atol=1e-12)
    assert np.all(d >= -1e-12)  # the bulk delay makes every delay causal
    assert np.all(d <= FS * 0.0214 / C + 1e-12)


def test_elevation_scales_the_delay_by_cos_el():
    pair = MicPair(spacing_m=0.05, axis_azimuth_deg=30.0)
    d = plane_wave_delays(pair, azimuth_deg=60.0, elevation_deg=40.0, fs=FS, c=C)
    expected = FS * 0.05 * np.cos(np.deg2rad(60)) * np.cos(np.deg2rad(40)) / C
    np.testing.assert_allclose(d[1] - d[0], expected, atol=1e-12)


def test_front_mic_leads_for_source_at_zero_degrees():
    pair = MicPair()
    d0 = plane_wave_delays(pair, azimuth_deg=0.0, fs=FS)
    d180 = plane_wave_delays(pair, azimuth_deg=180.0, fs=FS)
    assert d0[0] < d0[1] and d180[1] < d180[0]


@pytest.mark.parametrize("az", [45.0, 270.0, 160.0])
def test_plane_wave_channels_equal_exact_frequency_domain_delay(rng, az):
    # Oracle: exact DFT-domain delay by the law's delays; tolerance 1e-3 per unit tone
    # (the fractional-delay filter's -60 dB target; it actually reaches about -90 dB).
    pair = MicPair(spacing_m=0.0214)
    n = 2048
    at, amp_sum = bandlimited_periodic(rng, n)
    x = plane_wave(at(0.0), pair, azimuth_deg=az, fs=FS)
    assert x.shape == (2, n)
    u = pair.direction(az)
    r = pair.positions_m - np.asarray(pair.center_m)
    tau = -(r @ u) / C * FS + 0.5 * 0.0214 / C * FS  # law + documented bulk d/(2c)
    inner = slice(2 * DEFAULT_N_TAPS, n - 2 * DEFAULT_N_TAPS)
    for i in range(2):
        np.testing.assert_allclose(x[i, inner], at(tau[i])[inner], atol=1e-3 * amp_sum)


def test_cross_spectrum_phase_slope_gives_the_tdoa(rng):
    # Oracle: for x1 = x0 delayed by T, angle(S_01(w)) = w T.  A wide pair (0.1 m, T = 4.1
    # samples at 30 deg) fitted over 0..0.8 Nyquist; tolerance 1e-3 samples.
    pair = MicPair(spacing_m=0.1)
    s = rng.standard_normal(4 * FS)
    x = plane_wave(s, pair, azimuth_deg=30.0, fs=FS)
    n_fft = 1024
    frames = x[:, : (x.shape[1] // n_fft) * n_fft].reshape(2, -1, n_fft)
    spec = np.fft.rfft(frames * np.hanning(n_fft), axis=2)
    s01 = np.mean(spec[0] * np.conj(spec[1]), axis=0)
    w = 2 * np.pi * np.fft.rfftfreq(n_fft)
    band = (w > 0) & (w < 0.8 * np.pi)
    phase = np.unwrap(np.angle(s01[band]))
    slope = np.sum(w[band] * phase) / np.sum(w[band] ** 2)  # line through the origin
    np.testing.assert_allclose(slope, FS * 0.1 * np.cos(np.deg2rad(30)) / C, atol=1e-3)


def test_point_source_amplitude_and_delay_follow_one_over_four_pi_r(rng):
    # Oracle: s(t - R_i/c) / (4 pi R_i), with the delay done exactly in the DFT domain;
    # tolerance 1e-3 per unit tone divided by 4 pi R_i.
    pair = MicPair(center_m=(1.0, 2.0, 1.5), spacing_m=0.0214)
    src = np.array([1.3, 2.0, 1.5])  # 0.3 m away on the axis, endfire: near field
    n = 2048
    at, amp_sum = bandlimited_periodic(rng, n)
    x = point_source(at(0.0), pair, position_m=src, fs=FS, c=C)
    r = np.linalg.norm(pair.positions_m - src, axis=1)
    inner = slice(2 * DEFAULT_N_TAPS, n - 2 * DEFAULT_N_TAPS)
    for i in range(2):
        expected = at(FS * r[i] / C) / (4 * np.pi * r[i])
        np.testing.assert_allclose(
            x[i, inner], expected[inner], atol=1e-3 * amp_sum / (4 * np.pi * r[i])
        )


def test_point_source_geometry_values():
    pair = MicPair()
    delays, gains = point_source_geometry(pair, position_m=(2.0, 0.0, 0.0), fs=FS, c=C)
    r = np.array([2.0 - 0.0107, 2.0 + 0.0107])
    np.testing.assert_allclose(delays, FS * r / C, rtol=1e-12)
    np.testing.assert_allclose(gains, 1 / (4 * np.pi * r), rtol=1e-12)


def test_inputs_not_mutated_and_lengths_kept(rng):
    s = rng.standard_normal(777)
    s0 = s.copy()
    assert plane_wave(s, MicPair(), azimuth_deg=10.0, fs=FS).shape == (2, 777)
    assert point_source(s, MicPair(), position_m=(0.5, 0.5, 0.0), fs=FS).shape == (2, 777)
    np.testing.assert_array_equal(s, s0)


def test_bad_inputs_raise(rng):
    s = rng.standard_normal(100)
    with pytest.raises(ParameterError, match="pair"):
        plane_wave(s, 0.0214, azimuth_deg=0.0, fs=FS)
    with pytest.raises(ParameterError, match="azimuth_deg"):
        plane_wave(s, MicPair(), azimuth_deg=float("nan"), fs=FS)
    with pytest.raises(ParameterError, match="fs"):
        plane_wave(s, MicPair(), azimuth_deg=0.0, fs=0)
    with pytest.raises(ParameterError, match="signal"):
        plane_wave(np.ones((2, 100)), MicPair(), azimuth_deg=0.0, fs=FS)
    with pytest.raises(ParameterError, match="position_m"):
        point_source(s, MicPair(), position_m=MicPair().positions_m[0], fs=FS)
    with pytest.raises(ParameterError, match="position_m"):
        point_source(s, MicPair(), position_m=(1.0, 2.0), fs=FS)
