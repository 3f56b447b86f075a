"""The sensor model (issue 8, section 1): mic mismatch, high-pass corners, self-noise.

Oracles: exact transfer functions (full-length FFT ratios; ``scipy.signal.freqz`` of the
first-order section), the analog phase law ``atan(fc1/f) - atan(fc2/f)``, IEC 61672-1
A-weighting table values, and the closed-form null depth of a differential pair under
mismatch (:func:`enhancers.beam.differential.mismatch_null_depth_db`, derived in its docstring).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

import enhancers
from enhancers.beam.differential import mismatch_null_depth_db
from scenesim.errors import ParameterError
from scenesim.scene.compose import NoiseSource, Scene, SourcePlacement, render_images, render_scene
from scenesim.scene.sensors import (
    MicResponse,
    SensorModel,
    SensorTolerance,
    a_weighting_db,
    mems_self_noise_dba,
)

FS = 16000


def _broadside_images(x, sensors, fs=FS):
    """Speech image of a plane wave at 270 deg (both mics receive the same signal)."""
    scene = Scene(fs=fs, speech=SourcePlacement(azimuth_deg=270.0), noises=(), sensors=sensors)
    return render_images(scene, x, [])


def test_broadside_gain_and_phase_ratio_is_exactly_the_asked_mismatch(rng):
    # Oracle: the rear/front cross-spectrum over the auto-spectrum, bin by bin on the
    # full-length FFT, equals 10^(g/20) e^{j phi} (tolerance: rounding, 1e-9).
    x = rng.standard_normal(FS)
    sensors = SensorModel.from_mismatch(gain_db=0.7, phase_deg=3.0)
    img = _broadside_images(x, sensors).speech_image
    X1, X2 = np.fft.rfft(img[0]), np.fft.rfft(img[1])
    ratio = (X2 * np.conj(X1))[1:-1] / (np.abs(X1[1:-1]) ** 2)
    expected = 10 ** (0.7 / 20) * np.exp(1j * np.deg2rad(3.0))
    np.testing.assert_allclose(ratio, expected, rtol=1e-9, atol=1e-9)


def test_unequal_highpass_corners_give_the_analog_phase_law(rng):
    # Oracle 1: scipy.signal.freqz of the two first-order sections (exact, 1e-6 on bins
    # with energy, after the transient has decayed in zero padding).  Oracle 2: the analog
    # law atan(fc2/f) - atan(fc1/f) below 1 kHz, to 1.5 % (the bilinear transform's
    # warping: relative error ~(pi f / fs)^2 / 3 = 1.3 % at 1 kHz).
    n = FS
    x = np.concatenate([rng.standard_normal(n), np.zeros(n)])  # the IIR tail decays in the pad
    sensors = SensorModel.from_mismatch(highpass_hz=(80.0, 150.0))
    img = _broadside_images(x, sensors).speech_image
    X1, X2 = np.fft.rfft(img[0]), np.fft.rfft(img[1])
    f = np.fft.rfftfreq(x.size, 1 / FS)
    sel = (f > 20) & (f < 7000)
    measured = X2[sel] / X1[sel]
    h1 = sensors.mics[0].frequency_response(f[sel], fs=FS)
    h2 = sensors.mics[1].frequency_response(f[sel], fs=FS)
    np.testing.assert_allclose(measured, h2 / h1, rtol=1e-6)
    low = f[sel] < 1000
    analog = np.rad2deg(np.arctan(150.0 / f[sel][low]) - np.arctan(80.0 / f[sel][low]))
    np.testing.assert_allclose(np.rad2deg(np.angle(measured[low])), analog, rtol=0.015)


def test_sensor_model_is_linear_so_replay_stays_exact(rng):
    # Oracle: linearity; the mixture equals the sum of the components it is made of.
    sensors = SensorModel.from_mismatch(gain_db=-0.8, phase_deg=4.0, highpass_hz=(60.0, 110.0))
    scene = Scene(fs=FS, noises=(NoiseSource(field="diffuse"),), sensors=sensors, snr_db=5.0)
    r = render_scene(scene, rng.standard_normal(FS), [None])
    np.testing.assert_allclose(r.mixture, r.speech_image + r.noise_image, atol=1e-12)
    a, b = rng.standard_normal((2, 2, 4000))
    np.testing.assert_allclose(sensors.apply(a + b, fs=FS), sensors.apply(a, fs=FS) + sensors.apply(b, fs=FS), atol=1e-12)


def test_a_weighting_matches_iec_61672_table():
    # Oracle: IEC 61672-1 table, given to 0.1 dB at the exact base-ten frequencies
    # 1000 * 10^(0.1 (n - 30)) that stand for the nominal 31.5, 100, 250, 1k, 4k, 8k Hz.
    exponents = np.array([-15, -10, -6, 0, 6, 9])
    table = [-39.4, -19.1, -8.6, 0.0, 1.0, -1.1]
    got = a_weighting_db(1000.0 * 10 ** (0.1 * exponents))
    np.testing.assert_allclose(got, table, atol=0.05 + 1e-9)


def _iec_a_weighting_fir(fs: int, n_taps: int = 1025) -> np.ndarray:
    """An A-weighting FIR written independently of scenesim (IEC 61672-1 pole frequencies)."""
    f = np.linspace(0, fs / 2, 513)
    f2 = f**2
    ra = (12194.0**2 * f2**2) / (
        (f2 + 20.6**2) * np.sqrt((f2 + 107.7**2) * (f2 + 737.9**2)) * (f2 + 12194.0**2)
    )
    gain = ra * 10 ** (2.0 / 20)
    return sps.firwin2(n_taps, f, gain, fs=fs)


@pytest.mark.parametrize("level_dba, speech_spl", [(30.0, 65.0), (26.0, 60.0)])
def test_self_noise_a_weighted_level_re_speech_level(rng, level_dba, speech_spl):
    # Oracle: an independent A-weighting FIR on the self-noise image against the speech
    # power, which stands for speech_spl dB SPL.  The issue asks for 0.5 dB; the oracle
    # allows 0.1 dB (power estimate over 64000 samples: ~0.03 dB; FIR error < 0.02 dB), which
    # also catches forgetting the A-weighted fraction of white noise (0.18 dB at 16 kHz).
    sensors = SensorModel.from_mismatch(self_noise_dba=level_dba, speech_spl_db=speech_spl)
    scene = Scene(fs=FS, noises=(), sensors=sensors)
    speech = rng.standard_normal(4 * FS)
    r = render_scene(scene, speech, [])
    p_speech = np.mean(r.speech_image[0] ** 2)
    h = _iec_a_weighting_fir(FS)
    for ch in range(2):
        weighted = sps.fftconvolve(r.self_noise_image[ch], h, mode="valid")
        measured = speech_spl + 10 * np.log10(np.mean(weighted**2) / p_speech)
        assert measured == pytest.approx(level_dba, abs=0.1)
    # spatially white: independent between the mics (|rho| < 4/sqrt(n))
    rho = np.corrcoef(r.self_noise_image)[0, 1]
    assert abs(rho) < 4 / np.sqrt(speech.size)
    # and part of the noise image
    np.testing.assert_allclose(r.noise_image, r.self_noise_image, atol=0)


def test_self_noise_follows_the_acoustic_speech_level_not_the_mic_gain(rng):
    # A hotter front mic (+1 dB) must not move the self-noise: it is referenced to the
    # acoustic speech level at nominal sensitivity.
    speech = rng.standard_normal(FS)
    base = SensorModel.from_mismatch(self_noise_dba=30.0)
    hot = SensorModel((MicResponse(gain_db=1.0), MicResponse()), self_noise_dba=30.0)
    a = render_scene(Scene(fs=FS, noises=(), sensors=base), speech, [])
    b = render_scene(Scene(fs=FS, noises=(), sensors=hot), speech, [])
    np.testing.assert_allclose(a.self_noise_image, b.self_noise_image, rtol=1e-12)
    assert np.mean(b.speech_image[0] ** 2) / np.mean(a.speech_image[0] ** 2) == pytest.approx(10 ** 0.1)


def _null_depth_simulated(beta, theta_null, gain_db, phase_deg, rng):
    """Output power of the fixed pattern for a plane wave at the null re at 0 deg (same pair)."""
    n = 4 * FS
    white = rng.standard_normal(n)
    spec = np.fft.rfft(white)
    f = np.fft.rfftfreq(n, 1 / FS)
    spec[(f < 100) | (f > 7000)] = 0  # the band the closed form sums over
    x = np.fft.irfft(spec, n=n)
    sensors = SensorModel.from_mismatch(gain_db=gain_db, phase_deg=phase_deg)
    enh = enhancers.make("cardioid", beta=beta, eq=False)
    power = []
    for theta in (theta_null, 0.0):
        img = render_images(
            Scene(fs=FS, speech=SourcePlacement(azimuth_deg=theta), noises=(), sensors=sensors), x, []
        ).speech_image
        y = enh.process(img, fs=FS).output[0]
        power.append(np.mean(y[FS // 4 : -FS // 4] ** 2))
    return 10 * np.log10(power[0] / power[1]), f[(f >= 100) & (f <= 7000)]


@pytest.mark.parametrize(
    "beta, theta_null, gain_db, phase_deg",
    [(0.0, 180.0, 0.5, 2.0), (0.0, 180.0, 1.0, 5.0), (0.0, 180.0, 0.1, 0.5),
     (1.0, 270.0, 0.5, 2.0), (1.0, 270.0, 1.0, 0.0), (1.0, 90.0, 0.0, 3.0)],
)  # fmt: skip
def test_null_depth_under_mismatch_matches_the_closed_form(rng, beta, theta_null, gain_db, phase_deg):
    # Oracle: mismatch_null_depth_db (closed form, white source on the same band); the
    # issue's tolerance 0.5 dB.
    measured, freqs = _null_depth_simulated(beta, theta_null, gain_db, phase_deg, rng)
    closed = mismatch_null_depth_db(freqs, theta_null, beta=beta, rear_gain_db=gain_db, rear_phase_deg=phase_deg)
    assert measured == pytest.approx(closed, abs=0.5)
    assert closed > -60  # a real null: the mismatch, not the float floor, limits it


def test_ideal_sensors_null_broadside_to_the_float_floor(rng):
    # The idealisation the thesis preset keeps: identical mics null a broadside plane wave
    # exactly (why its EB numbers are an upper bound).
    measured, _ = _null_depth_simulated(1.0, 270.0, 0.0, 0.0, rng)
    assert measured < -200


def test_tolerance_draws_are_seeded_bounded_and_recorded():
    tol = SensorTolerance(gain_tol_db=1.0, phase_tol_deg=2.0, highpass_tol_hz=30.0)
    nominal = SensorModel.from_mismatch(highpass_hz=100.0, self_noise_dba=30.0)
    draws = [tol.draw(nominal, seed=s) for s in range(50)]
    assert draws[3] == tol.draw(nominal, seed=3)  # same seed, same phone
    assert len({d.mics[1].gain_db for d in draws}) == 50
    for d in draws:
        assert all(abs(m.gain_db) <= 1.0 and 70.0 <= m.highpass_hz <= 130.0 for m in d.mics)
        assert abs(d.mics[1].phase_deg) <= 2.0 and d.mics[0].phase_deg == 0.0
        rec = d.describe()
        assert rec["mic_gain_db"] == pytest.approx(d.mics[1].gain_db - d.mics[0].gain_db)
        assert rec["self_noise_dba"] == 30.0
    # the spread really spans the interval (uniform draws, 50 of them)
    gains = np.array([d.mics[0].gain_db for d in draws])
    assert gains.min() < -0.7 and gains.max() > 0.7


def test_mems_datasheet_snr_to_self_noise():
    assert mems_self_noise_dba(64.0) == 30.0


@pytest.mark.parametrize(
    "kwargs, name",
    [({"gain_db": 30.0}, "gain_db"), ({"phase_deg": 120.0}, "phase_deg"), ({"highpass_hz": -1.0}, "highpass_hz")],
)
def test_bad_mic_parameters_name_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        MicResponse(**kwargs)


def test_highpass_corner_above_nyquist_is_refused_when_the_scene_is_built():
    with pytest.raises(ParameterError, match="highpass_hz"):
        Scene(fs=8000, noises=(), sensors=SensorModel.from_mismatch(highpass_hz=5000.0))
