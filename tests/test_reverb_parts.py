"""Direct / early / late split of the speech image and the RIR's acoustic parameters."""

import numpy as np
import pytest

from scenesim.room.reverb_parts import critical_distance_m, rir_acoustics, speech_parts, split_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import Scene, SourcePlacement, render_images
from scenesim.scene.geometry import MicPair
from scenesim.scene.sensors import SensorModel

FS = 16000


def _room_scene(**kw):
    return Scene(
        pair=MicPair((2.0, 1.8, 0.9)),
        room=ShoeBox((5.0, 4.0, 2.8), rt60_s=0.4),
        speech=SourcePlacement(45.0, 1.0),
        noises=(),
        reference="early50",
        sensors=SensorModel.from_mismatch(gain_db=0.5, phase_deg=2.0, highpass_hz=(90.0, 120.0)),
        **kw,
    )


def _speech(n=FS):
    return np.random.default_rng(3).standard_normal(n)


def test_parts_sum_to_the_speech_image_and_target_is_the_early50_reference():
    # Oracle: linearity -- the RIR parts sum to the RIR exactly, convolution and the sensors
    # are linear, so the part images sum to the rendered image (tolerance: rounding, 1e-12
    # of the peak).  The scene's own "early50" reference is direct + early at channel 0.
    scene = _room_scene()
    s = _speech()
    images = render_images(scene, s)
    parts = speech_parts(images, s)
    peak = np.max(np.abs(images.speech_image))
    assert np.max(np.abs(parts.direct + parts.early + parts.late - images.speech_image)) < 1e-12 * peak
    assert np.max(np.abs(parts.target[0] - images.reference[0])) < 1e-12 * peak
    # Every part carries energy in a 0.4 s room.
    for part in (parts.direct, parts.early, parts.late):
        assert np.mean(part**2) > 1e-4 * np.mean(images.speech_image**2)


def test_free_field_is_all_direct():
    scene = Scene(noises=())
    s = _speech()
    images = render_images(scene, s)
    parts = speech_parts(images, s)
    assert not parts.reverberant
    np.testing.assert_array_equal(parts.direct, images.speech_image)
    assert not np.any(parts.early) and not np.any(parts.late)


def test_split_rir_sums_exactly():
    h = np.random.default_rng(0).standard_normal((2, 500))
    hd = np.zeros((2, 40))
    hd[:, 20] = h[:, 20]
    d, e, late = split_rir(h, hd, 300)
    np.testing.assert_array_equal(d + e + late, h)
    assert not np.any(late[:, :300]) and not np.any(e[:, 300:])


def test_rir_acoustics_closed_form():
    # Oracle: a direct impulse A at n0 and an exponential tail B r^(n - n0) after it.
    # E_tail over [n0+1, N) is a geometric sum; DRR and C50 follow in closed form, and the
    # Schroeder curve of the tail is exactly exponential: T30 = EDT... = 60 / (-20 log10(r) fs)
    # (the direct spike only shifts the curve before -5 dB).  Tolerances: DRR/C50 1e-9 dB
    # (sums), T30 1 % (line fit over a sampled curve).
    fs, n0, n_taps = FS, 40, 3 * FS
    a, b, t60 = 1.0, 0.05, 0.5
    r = 10.0 ** (-3.0 / (t60 * fs))  # amplitude -60 dB after t60
    h = np.zeros(n_taps)
    h[n0] = a
    k = np.arange(1, n_taps - n0)
    h[n0 + 1 :] = b * r**k
    hd = np.zeros(n0 + 1)
    hd[n0] = a
    cut = n0 + int(0.05 * fs)

    def geo(k0, k1):  # sum_{k=k0}^{k1-1} (b r^k)^2
        q = r**2
        return b**2 * (q**k0 - q**k1) / (1 - q)

    tail_all = geo(1, n_taps - n0)
    drr = 10 * np.log10(a**2 / tail_all)
    c50 = 10 * np.log10((a**2 + geo(1, cut - n0)) / geo(cut - n0, n_taps - n0))
    out = rir_acoustics(h, hd, fs=fs, cut_sample=cut)
    assert out["drr_db"] == pytest.approx(drr, abs=1e-9)
    assert out["c50_db"] == pytest.approx(c50, abs=1e-9)
    assert out["t30_s"] == pytest.approx(t60, rel=0.01)


def test_critical_distance_sabine():
    # r_c = 0.057 sqrt(V / T): 5 x 4 x 2.8 m = 56 m^3 at 0.5 s -> 0.603 m.
    assert critical_distance_m(56.0, 0.5) == pytest.approx(0.057 * np.sqrt(112.0), rel=1e-12)


def test_early_window_moves_the_cut():
    # Closed form: cut = ceil((r0 / c + window) * fs); a shorter window moves energy from the
    # early to the late part, the direct part and the sum stay (tolerance: rounding).
    scene = _room_scene()
    s = _speech()
    images = render_images(scene, s)
    p20, p50 = speech_parts(images, s, early_window_s=0.02), speech_parts(images, s)
    r0 = float(np.linalg.norm(scene.pair.positions_m[0] - scene.speech.position(scene.pair)))
    assert p20.cut_sample == int(np.ceil((r0 / scene.speed_of_sound_mps + 0.02) * FS))
    assert p50.cut_sample - p20.cut_sample in (480, 481)
    np.testing.assert_array_equal(p20.direct, p50.direct)
    assert np.sum(p20.early**2) < np.sum(p50.early**2) and np.sum(p20.late**2) > np.sum(p50.late**2)
    np.testing.assert_allclose(p20.early + p20.late, p50.early + p50.late, atol=1e-12 * np.max(np.abs(s)))
