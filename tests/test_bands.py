"""Octave filter bank (complementary, zero phase) and banded/air rendering."""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.room.air import AirAbsorption
from scenesim.room.bands import (
    OCTAVE_CENTERS_HZ,
    active_bands,
    band_weights,
    combine_bands,
    exact_midband_hz,
    octave_rt60,
    split_bands,
)
from scenesim.room.ism import image_source_rir
from scenesim.room.render import band_rirs, room_rir
from scenesim.room.shoebox import ShoeBox

FS = 16000


def test_weights_sum_to_one_and_select_their_band():
    """Oracle: definition -- columns sum to 1 (1e-15), weights in [0, 1], and each centre
    +-1/8 octave lies entirely in its own band (flat region of +-1/4 octave)."""
    f = np.fft.rfftfreq(8192, 1 / FS)
    w = band_weights(f, OCTAVE_CENTERS_HZ)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, rtol=0, atol=1e-15)
    assert w.min() >= 0 and w.max() <= 1
    for b, fc in enumerate(OCTAVE_CENTERS_HZ):
        near = (f > fc * 2 ** -0.125) & (f < fc * 2 ** 0.125)
        np.testing.assert_allclose(w[b, near], 1.0, atol=1e-12)
    # Half way between two centres the crossover splits evenly.
    mid = band_weights([np.sqrt(500.0 * 1000.0)], OCTAVE_CENTERS_HZ)[:, 0]
    np.testing.assert_allclose(mid[2:4], [0.5, 0.5], atol=1e-12)


def test_split_sums_to_a_delta_and_combine_inverts():
    """The bank sums to a delta: split bands add back to the input to 1e-12 (incl. the taps
    next to t = 0 where the zero-phase ringing is cut); identical band signals combine to themselves."""
    x = np.random.default_rng(0).standard_normal((2, 3000))
    bands = split_bands(x, FS, OCTAVE_CENTERS_HZ)
    assert bands.shape == (7, 2, 3000)
    np.testing.assert_allclose(bands.sum(axis=0), x, atol=1e-12)
    np.testing.assert_allclose(combine_bands(np.stack([x] * 7), FS, OCTAVE_CENTERS_HZ), x, atol=1e-12)
    with pytest.raises(ParameterError, match="band_signals"):
        combine_bands(np.stack([x] * 3), FS, OCTAVE_CENTERS_HZ)


def test_band_table_and_exact_midbands():
    """ISO 266 exact octave midbands 1000 * 10^(3k/10); at fs = 8 kHz the 8 kHz band is above Nyquist."""
    np.testing.assert_allclose(exact_midband_hz((125, 1000, 8000)), [125.89254, 1000.0, 7943.2823], rtol=1e-6)
    np.testing.assert_array_equal(active_bands(OCTAVE_CENTERS_HZ, 8000), [True] * 6 + [False])
    with pytest.raises(ParameterError, match="bands_hz"):
        band_weights([100.0], (1000, 500))


def test_flat_table_renders_as_the_flat_room():
    """A banded room whose every band has the same absorption equals the flat room's ISM RIR
    (complementary bank; 1e-10 of the peak)."""
    flat = ShoeBox((5, 4, 3), 0.3)
    banded = ShoeBox((5, 4, 3), (0.3,) * 7, bands_hz=OCTAVE_CENTERS_HZ)
    kw = dict(fs=FS, length_s=0.25)
    h0 = image_source_rir(flat, (1, 1.2, 1.5), [(3.5, 2.5, 1.4), (3.52, 2.5, 1.4)], **kw)
    h1 = room_rir(banded, (1, 1.2, 1.5), [(3.5, 2.5, 1.4), (3.52, 2.5, 1.4)], highpass_hz=None, **kw)
    np.testing.assert_allclose(h1, h0, rtol=0, atol=1e-10 * np.abs(h0).max())


def test_banded_decay_follows_each_band():
    """Octave T30 of a banded RIR rises where the band's absorption is low (order check:
    Sabine predicts 3x longer at 250 Hz than at 4 kHz here; measured ratio must exceed 2)."""
    room = ShoeBox((5, 4, 3), (0.08, 0.08, 0.15, 0.2, 0.25, 0.3, 0.3), bands_hz=OCTAVE_CENTERS_HZ)
    h = room_rir(room, (1, 1.2, 1.5), (3.5, 2.5, 1.4), fs=FS, length_s=1.0)[0]
    t = octave_rt60(h, FS, (250, 4000))
    assert t[0] / t[1] > 2.0


def test_air_on_direct_path_is_the_iso_attenuation():
    """Oracle: ISO 9613-1 closed form.  Direct path only (max_order 0), r = 8 m, 20 C / 20 % RH:
    each band's RIR with air equals the RIR without, times 10^(-a_b c t / 20) at the peak tap
    (1e-12), which is 10^(-a_b r / 20) up to the half-sample offset of the tap from r / c
    (<= a_b * c / (2 fs) dB: 1.1e-4 relative at 8 kHz; asserted 2e-4)."""
    air = AirAbsorption(temperature_c=20.0, humidity_pct=20.0)
    room = ShoeBox((12, 5, 3), 0.3, air=air)
    src, mic = (1.5, 2.5, 1.5), (9.5, 2.5, 1.5)
    with_air = band_rirs(room, src, mic, fs=FS, max_order=0)
    without = image_source_rir(ShoeBox((12, 5, 3), 0.3), src, mic, fs=FS, max_order=0)[0]
    peak = int(np.argmax(np.abs(without)))
    a = air.db_per_m(exact_midband_hz(OCTAVE_CENTERS_HZ))
    r = 8.0
    ratio = with_air[:, 0, peak] / without[peak]
    np.testing.assert_allclose(ratio, 10 ** (-a * (peak / FS) * 343.0 / 20), rtol=1e-12)
    np.testing.assert_allclose(ratio, 10 ** (-a * r / 20), rtol=2e-4)


def test_room_rir_highpasses_by_default():
    """room_rir (what scenes render) = image_source_rir with the 20 Hz causal high-pass, bit for
    bit; the raw sum's DC build-up (mean/peak 3.7 % here) is gone (7e-7 measured; asserted < 1e-4)."""
    room = ShoeBox((6, 5, 3), 0.15)
    kw = dict(fs=FS, length_s=0.8)
    raw = image_source_rir(room, (1.3, 1.5, 1.4), (3.5, 2.5, 1.5), **kw)[0]
    h = room_rir(room, (1.3, 1.5, 1.4), (3.5, 2.5, 1.5), **kw)[0]
    np.testing.assert_array_equal(h, image_source_rir(room, (1.3, 1.5, 1.4), (3.5, 2.5, 1.5), highpass_hz=20.0, **kw)[0])
    assert abs(raw.mean()) / np.abs(raw).max() > 0.01
    assert abs(h.mean()) / np.abs(h).max() < 1e-4
    banded = ShoeBox((6, 5, 3), (0.15,) * 7, bands_hz=OCTAVE_CENTERS_HZ)
    np.testing.assert_allclose(room_rir(banded, (1.3, 1.5, 1.4), (3.5, 2.5, 1.5), **kw)[0], h,
                               rtol=0, atol=1e-10 * np.abs(h).max())


def test_scene_renders_a_banded_room_with_air():
    """Scenes take rooms with bands and air through cached_rir -> room_rir (oracle: room_rir
    called directly, bit-identical; the speech image is that RIR convolved, 1e-9 of its peak)."""
    from scipy import signal as sps

    from scenesim.scene.compose import Scene, SourcePlacement, render_images
    from scenesim.scene.geometry import MicPair

    room = ShoeBox((4.0, 3.5, 2.8), (0.1, 0.15, 0.25, 0.35, 0.45, 0.55, 0.6), bands_hz=OCTAVE_CENTERS_HZ,
                   air=AirAbsorption(temperature_c=22, humidity_pct=45))
    scene = Scene(room=room, pair=MicPair(center_m=(2.0, 1.6, 1.4)), max_order=3,
                  speech=SourcePlacement(azimuth_deg=45.0, distance_m=1.0), noises=())
    rng = np.random.default_rng(0)
    speech = rng.standard_normal(FS // 2)
    images = render_images(scene, speech, [])
    src = scene.pair.source_position(45.0, 1.0)
    h = room_rir(room, src, scene.pair.positions_m, fs=FS, max_order=3)
    np.testing.assert_array_equal(images.rirs["speech"], h)
    expected = sps.fftconvolve(speech[None, :], h, axes=1)[:, : speech.size]
    np.testing.assert_allclose(images.speech_image, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
