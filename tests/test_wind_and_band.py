"""Wind with the Corcos coherence, babble from spread talkers, and the in-band SNR (issue 8, section 2).

Oracles: the Corcos (1964) model as written in algorithms.md 4b (|gamma| ~0.66 at 100 Hz and
~0.12 at 500 Hz for 2.14 cm, 5 m/s along the flow), Welch coherence estimates averaged over
third-octave bands, and powers by Parseval.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import NoiseSource, Scene, render_scene, spread_positions
from scenesim.scene.geometry import MicPair
from scenesim.scene.mixing import bandlimit
from scenesim.scene.noise_fields import corcos_coherence, wind_noise

FS = 16000
D = 0.0214


def _band_coherence(x, fs, nperseg=4096):
    """Complex coherence E[X1 X2*]/sqrt(P1 P2) per third-octave band (Welch, averaged in band)."""
    f, pxy = sps.csd(x[1], x[0], fs, nperseg=nperseg)  # scipy: E[conj(X1) X0] -> E[X0 X1*]
    _, p0 = sps.welch(x[0], fs, nperseg=nperseg)
    _, p1 = sps.welch(x[1], fs, nperseg=nperseg)
    centres = 1000.0 * 2.0 ** (np.arange(-12, 10) / 3.0)
    out = []
    for fc in centres[(centres > 40) & (centres < 7000)]:
        sel = (f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))
        out.append((fc, np.mean(pxy[sel]) / np.sqrt(np.mean(p0[sel]) * np.mean(p1[sel])), sel))
    return f, out


def test_corcos_magnitudes_quoted_in_the_design_notes():
    g = corcos_coherence([100.0, 500.0], D, wind_speed_mps=5.0)
    np.testing.assert_allclose(np.abs(g), [0.66, 0.12], atol=0.005)


@pytest.mark.parametrize("speed, flow", [(5.0, 0.0), (2.0, 0.0), (10.0, 90.0), (5.0, 45.0)])
def test_wind_field_coherence_within_0_05_of_the_model(rng, speed, flow):
    # Oracle: the Corcos model averaged over the same third-octave bins; tolerance 0.05
    # (the issue's).  Estimator: 60 s, 4096-point Welch -> ~470 averages per bin, times the
    # bins of a band: bias and spread of the band estimate below 0.02.
    x = wind_noise(60 * FS, D, fs=FS, wind_speed_mps=speed, flow_azimuth_deg=flow, rng=rng)
    f, bands = _band_coherence(x, FS)
    g = corcos_coherence(f, D, wind_speed_mps=speed, flow_azimuth_deg=flow)
    for fc, measured, sel in bands:
        assert abs(measured - np.mean(g[sel])) < 0.05, f"{fc:.0f} Hz"


def test_wind_tends_to_incoherent_at_speech_frequencies(rng):
    x = wind_noise(30 * FS, D, fs=FS, wind_speed_mps=5.0, rng=rng)
    _, bands = _band_coherence(x, FS)
    assert all(abs(c) < 0.1 for fc, c, _ in bands if fc > 1000)
    assert any(abs(c) > 0.5 for fc, c, _ in bands if fc < 100)


def test_wind_keeps_the_source_spectrum(rng):
    # Mixing per frequency with a unitary-like factor keeps each channel's power spectrum.
    src = sps.lfilter(*sps.butter(2, 200, fs=FS), rng.standard_normal((2, 20 * FS)))
    x = wind_noise(20 * FS, D, fs=FS, wind_speed_mps=5.0, source=src)
    np.testing.assert_allclose(np.mean(x**2, axis=1), np.mean(src**2, axis=1), rtol=0.05)


def test_scene_wind_field_is_seeded_and_mixes_at_the_snr(rng):
    speech = rng.standard_normal(2 * FS)
    scene = Scene(fs=FS, noises=(NoiseSource(field="wind", wind_speed_mps=8.0),), snr_db=3.0, seed=4)
    a = render_scene(scene, speech, [None])
    b = render_scene(scene, speech, [None])
    np.testing.assert_array_equal(a.noise_image, b.noise_image)
    snr = 10 * np.log10(np.mean(a.speech_image[0] ** 2) / np.mean(a.noise_image[0] ** 2))
    assert snr == pytest.approx(3.0, abs=1e-9)


def test_band_snr_sets_the_snr_in_the_band_not_the_full_band(rng):
    # A wind-like noise whose power lies mostly below 100 Hz: at 0 dB full band it is far
    # below 0 dB in 100 Hz - 7 kHz; with snr_band_hz the band SNR is the one set.
    n = 4 * FS
    speech = sps.lfilter(*sps.butter(2, [200, 4000], btype="band", fs=FS), rng.standard_normal(n))
    low = sps.lfilter(*sps.butter(4, 60, fs=FS), rng.standard_normal(n + 100))
    band = (100.0, 7000.0)
    full = render_scene(Scene(fs=FS, noises=(NoiseSource(field="diffuse"),)), speech, [low])
    inband = render_scene(Scene(fs=FS, noises=(NoiseSource(field="diffuse"),), snr_band_hz=band), speech, [low])

    def snr(x, y, b=None):
        if b:
            x, y = bandlimit(x, FS, b), bandlimit(y, FS, b)
        return 10 * np.log10(np.mean(x**2) / np.mean(y**2))

    assert snr(full.speech_image[0], full.noise_image[0]) == pytest.approx(0.0, abs=1e-9)
    assert snr(full.speech_image[0], full.noise_image[0], band) > 20.0
    assert snr(inband.speech_image[0], inband.noise_image[0], band) == pytest.approx(0.0, abs=1e-9)
    assert snr(inband.speech_image[0], inband.noise_image[0]) < -20.0


def test_band_outside_nyquist_is_refused():
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError, match="snr_band_hz"):
        Scene(fs=8000, snr_band_hz=(100.0, 7000.0))


def test_spread_babble_sources_lie_in_the_room_away_from_the_pair():
    room = ShoeBox((5.0, 4.0, 2.8), absorption=0.4)
    pair = MicPair((2.0, 1.8, 0.9))
    src = NoiseSource(field="spread", n_sources=12)
    scene = Scene(room=room, pair=pair, far_field=False, noises=(src,), seed=2)
    p = spread_positions(scene, src, 0)
    assert p.shape == (12, 3)
    assert np.all(p >= 0.2 - 1e-12) and np.all(p <= np.array(room.dims_m) - 0.2 + 1e-12)
    assert np.all(np.linalg.norm(p - np.array(pair.center_m), axis=1) >= 0.5)
    assert not np.allclose(p, spread_positions(Scene(room=room, pair=pair, far_field=False, noises=(src,), seed=3), src, 0))


def test_spread_field_in_free_field_is_nearly_diffuse(rng):
    # Many plane waves from directions uniform on the sphere approach the diffuse coherence
    # sinc(2 f d / c); with 64 sources the band-averaged coherence is within 0.15 of it.
    src = NoiseSource(field="spread", n_sources=64)
    r = render_scene(Scene(fs=FS, noises=(src,)), rng.standard_normal(2 * FS), [rng.standard_normal(2 * FS)])
    f, bands = _band_coherence(r.noise_image, FS, nperseg=1024)
    theory = np.sinc(2 * f * D / 343.0)
    for fc, measured, sel in bands:
        assert abs(measured.real - np.mean(theory[sel])) < 0.15, f"{fc:.0f} Hz"
