"""Scenes: keys, determinism, free-field and room rendering, mixing, the RIR cache.

Oracles are named per test: scipy.signal.fftconvolve with scenesim.room.ism.image_source_rir
called directly (room images), the plane-wave law (broadside equality), the SNR
definition recomputed with numpy, linear superposition, and a fresh subprocess for
key stability.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import signal as sps

from scenesim.errors import ParameterError
from scenesim.room import cache
from scenesim.room.ism import image_source_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import (
    NoiseSource,
    Scene,
    SourcePlacement,
    render_images,
    render_scene,
)
from scenesim.scene.freefield import plane_wave, point_source
from scenesim.scene.geometry import MicPair
from scenesim.scene.noise_fields import diffuse_noise

FS = 16000
N = FS  # 1 s signals keep the suite fast


@pytest.fixture
def speech(rng):
    # Speech-like: noise bursts (active ~50 %) so the active and total modes differ.
    gate = (np.arange(N) % 4000) < 2000
    return rng.standard_normal(N) * gate


@pytest.fixture
def noise(rng):
    return rng.standard_normal(N + 500)


def small_room_scene(**kwargs):
    room = ShoeBox((4.0, 3.5, 2.8), absorption=0.5)
    base = dict(room=room, pair=MicPair(center_m=(2.0, 1.6, 1.4)), max_order=3)
    base.update(kwargs)
    return Scene(**base)


# ------------------------------------------------------------------ keys
def test_same_scene_same_key_and_every_field_changes_it():
    base = Scene()
    assert base.key() == Scene().key()
    assert len(base.key()) == 64 and int(base.key(), 16) >= 0
    variants = [
        dataclasses.replace(base, fs=8000),
        dataclasses.replace(base, pair=MicPair(spacing_m=0.03)),
        dataclasses.replace(base, pair=MicPair(center_m=(0.0, 0.0, 0.1))),
        dataclasses.replace(base, speech=SourcePlacement(azimuth_deg=46.0)),
        dataclasses.replace(base, speech=SourcePlacement(distance_m=2.0)),
        dataclasses.replace(base, speech=SourcePlacement(elevation_deg=10.0)),
        dataclasses.replace(base, speech=SourcePlacement(position_m=(1.0, 1.0, 0.0))),
        dataclasses.replace(base, noises=(NoiseSource(azimuth_deg=180.0),)),
        dataclasses.replace(base, noises=(NoiseSource(field="diffuse"),)),
        dataclasses.replace(base, noises=(NoiseSource(gain_db=-3.0),)),
        dataclasses.replace(base, noises=()),
        dataclasses.replace(base, snr_db=5.0),
        dataclasses.replace(base, far_field=False),
        dataclasses.replace(base, snr_mode="active"),
        dataclasses.replace(base, reference="early50"),
        dataclasses.replace(base, sensor_noise_db=-60.0),
        dataclasses.replace(base, max_order=2),
        dataclasses.replace(base, seed=1),
        small_room_scene(),
        small_room_scene(room=ShoeBox((4.0, 3.5, 2.8), absorption=0.4)),
        small_room_scene(room=ShoeBox((4.0, 3.5, 2.8), rt60_s=0.3)),
    ]
    keys = [v.key() for v in variants]
    assert base.key() not in keys
    assert len(set(keys)) == len(keys)


def test_key_is_stable_across_processes():
    # Oracle: a fresh interpreter with a different hash seed computes the same key.
    code = (
        "from scenesim.scene.compose import Scene, NoiseSource;"
        "print(Scene(snr_db=5, noises=(NoiseSource(field='diffuse'),)).key())"
    )
    env = dict(os.environ, PYTHONHASHSEED="12345")
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    assert out.stdout.strip() == Scene(snr_db=5.0, noises=(NoiseSource(field="diffuse"),)).key()


def test_integral_floats_and_ints_hash_alike():
    assert Scene(snr_db=5).key() == Scene(snr_db=5.0).key()


# ------------------------------------------------------------------ free field
def test_far_field_reference_is_channel_0_and_broadside_noise_is_equal_on_both_mics(speech, noise):
    r = render_scene(Scene(), speech, [noise])
    assert r.mixture.shape == r.speech_image.shape == r.noise_image.shape == (2, N)
    assert r.reference.shape == (1, N)
    np.testing.assert_array_equal(r.reference[0], r.speech_image[0])
    # Oracle: plane_wave called directly (45 deg, unit amplitude).
    np.testing.assert_allclose(
        r.speech_image, plane_wave(speech, MicPair(), azimuth_deg=45.0, fs=FS), atol=1e-12
    )
    # Plane-wave law: at 270 deg (broadside) both mics receive the same signal (1e-12).
    np.testing.assert_allclose(r.noise_image[0], r.noise_image[1], atol=1e-12)
    np.testing.assert_allclose(r.mixture, r.speech_image + r.noise_image, atol=1e-12)


def test_near_field_free_field_uses_point_sources(speech, noise):
    scene = Scene(far_field=False, speech=SourcePlacement(azimuth_deg=0.0, distance_m=0.5))
    r = render_scene(scene, speech, [noise])
    # Oracle: point_source at the placement's position (1/(4 pi R) law, tested in test_freefield).
    expected = point_source(speech, MicPair(), position_m=(0.5, 0.0, 0.0), fs=FS)
    np.testing.assert_allclose(r.speech_image, expected, atol=1e-12)
    np.testing.assert_array_equal(r.reference[0], r.speech_image[0])


def test_absolute_position_gives_the_same_far_field_image_as_its_angles(speech, noise):
    # Oracle: geometry; a position at azimuth 45 deg, elevation 30 deg renders like the angles (1e-12).
    pair = MicPair(center_m=(1.0, -2.0, 0.5), axis_azimuth_deg=20.0)
    pos = np.asarray(pair.center_m) + 3.0 * pair.direction(45.0, 30.0)
    by_pos = render_images(
        Scene(pair=pair, speech=SourcePlacement(position_m=tuple(pos))), speech, [noise]
    )
    by_angle = render_images(
        Scene(pair=pair, speech=SourcePlacement(45.0, 3.0, 30.0)), speech, [noise]
    )
    np.testing.assert_allclose(by_pos.speech_image, by_angle.speech_image, atol=1e-12)


@pytest.mark.parametrize("mode", ["total", "active"])
@pytest.mark.parametrize("snr_db", [-5.0, 0.0, 20.0])
def test_rendered_snr_equals_target(speech, noise, mode, snr_db):
    # Oracle: 10 log10(P_s / P_n) at channel 0 recomputed; tolerance 0.01 dB.
    from scenesim.scene.mixing import active_speech_power

    r = render_scene(Scene(snr_db=snr_db, snr_mode=mode), speech, [noise])
    p_s = (
        active_speech_power(r.speech_image[0], FS)
        if mode == "active"
        else np.mean(r.speech_image[0] ** 2)
    )
    measured = 10 * np.log10(p_s / np.mean(r.noise_image[0] ** 2))
    np.testing.assert_allclose(measured, snr_db, atol=0.01)


def test_mixing_many_snrs_reuses_one_rendering(speech, noise):
    images = render_images(Scene(), speech, [noise])
    before = images.noise_image.copy()
    a, b = images.mix(0.0), images.mix(10.0)
    np.testing.assert_allclose(b.noise_gain / a.noise_gain, 10 ** (-10 / 20), rtol=1e-12)
    np.testing.assert_array_equal(a.speech_image, b.speech_image)
    np.testing.assert_array_equal(images.noise_image, before)
    assert not images.noise_image.flags.writeable  # images cannot be altered by a caller
    a.mixture[:] = 0.0  # rendered outputs are the caller's own arrays
    np.testing.assert_array_equal(
        images.mix(0.0).mixture, images.speech_image + images.mix(0.0).noise_image
    )


def test_noise_sources_superpose_with_their_gains(speech, noise, rng):
    # Oracle: linearity; image(n1 + g n2) = image(n1) + g image(n2), g = 10^(-6/20); 1e-12.
    noise2 = rng.standard_normal(N)
    s1 = NoiseSource(azimuth_deg=200.0)
    s2 = NoiseSource(azimuth_deg=90.0, gain_db=-6.0)
    both = render_images(Scene(noises=(s1, s2)), speech, [noise, noise2]).noise_image
    one = render_images(Scene(noises=(s1,)), speech, [noise]).noise_image
    two = render_images(
        Scene(noises=(dataclasses.replace(s2, gain_db=0.0),)), speech, [noise2]
    ).noise_image
    np.testing.assert_allclose(both, one + 10 ** (-6 / 20) * two, atol=1e-12)


def test_longer_noise_is_cut_and_inputs_are_not_mutated(speech, noise):
    s0, n0 = speech.copy(), noise.copy()
    long_ = render_images(Scene(), speech, [noise]).noise_image
    cut = render_images(Scene(), speech, [noise[:N]]).noise_image
    np.testing.assert_array_equal(long_, cut)
    np.testing.assert_array_equal(speech, s0)
    np.testing.assert_array_equal(noise, n0)


def test_diffuse_field_from_two_channels_matches_the_generator(speech, rng):
    src = rng.standard_normal((2, N + 10))
    r = render_images(Scene(noises=(NoiseSource(field="diffuse"),)), speech, [src])
    # Oracle: diffuse_noise called directly on the cut channels (same arithmetic, 1e-12).
    np.testing.assert_allclose(
        r.noise_image, diffuse_noise(N, MicPair(), fs=FS, source=src[:, :N]), atol=1e-12
    )


def test_rendering_is_deterministic_for_a_seed(speech):
    scene = Scene(
        noises=(NoiseSource(field="diffuse"), NoiseSource(field="incoherent"), NoiseSource()),
        sensor_noise_db=-40.0,
        seed=7,
    )
    a = render_scene(scene, speech, [None, None, None])
    b = render_scene(scene, speech, [None, None, None])
    np.testing.assert_array_equal(a.mixture, b.mixture)
    c = render_scene(dataclasses.replace(scene, seed=8), speech, [None, None, None])
    assert not np.allclose(a.noise_image, c.noise_image)


def test_sensor_noise_is_counted_in_the_noise_image(speech, noise):
    # Oracle: independent noises add in power: SNR = -10 log10(10^(-snr/10) + 10^(sensor/10)).
    # Tolerance 0.1 dB (the cross term of independent 1 s noises is ~0.01 of the power).
    r = render_scene(Scene(snr_db=10.0, sensor_noise_db=-10.0), speech, [noise])
    measured = 10 * np.log10(np.mean(r.speech_image[0] ** 2) / np.mean(r.noise_image[0] ** 2))
    np.testing.assert_allclose(measured, -10 * np.log10(10 ** (-1.0) + 10 ** (-1.0)), atol=0.1)
    np.testing.assert_allclose(r.mixture, r.speech_image + r.noise_image, atol=1e-12)


def test_scene_without_noise_gives_a_clean_mixture(speech):
    r = render_scene(Scene(noises=()), speech, [])
    assert r.noise_gain == 0.0
    np.testing.assert_array_equal(r.mixture, r.speech_image)


# ------------------------------------------------------------------ room
def test_room_speech_image_is_speech_convolved_with_the_ism_rir(speech, noise):
    scene = small_room_scene()
    r = render_scene(scene, speech, [noise])
    src = scene.pair.source_position(45.0, 1.0)
    # Scenes render through scenesim.room.render.room_rir: the ISM RIR with a 20 Hz high-pass by default.
    h = image_source_rir(scene.room, src, scene.pair.positions_m, fs=FS, max_order=3, highpass_hz=20.0)
    # Oracle: scipy.signal.fftconvolve with the ISM's RIR; tolerance 1e-9 of the peak.
    expected = sps.fftconvolve(speech[None, :], h, axes=1)[:, :N]
    np.testing.assert_allclose(r.speech_image, expected, atol=1e-9 * np.abs(expected).max())
    # The reference is the direct path only: the order-0 RIR (1/(4 pi r) at r/c).
    h0 = image_source_rir(scene.room, src, scene.pair.positions_m[:1], fs=FS, max_order=0)
    h0_hp = image_source_rir(scene.room, src, scene.pair.positions_m[:1], fs=FS, max_order=0, highpass_hz=20.0)
    expected_ref = sps.fftconvolve(speech[None, :], h0_hp, axes=1)[:, :N]
    np.testing.assert_allclose(r.reference, expected_ref, atol=1e-9 * np.abs(expected_ref).max())
    r0 = np.linalg.norm(scene.pair.positions_m[0] - src)
    assert np.argmax(h0[0]) == round(r0 * FS / scene.room.c)
    # DC gain of the windowed sinc is 1 to ~1e-3, so the taps sum to 1/(4 pi r0).
    np.testing.assert_allclose(h0.sum(), 1 / (4 * np.pi * r0), rtol=5e-3)
    # ... and it is not the reverberant channel 0.
    assert np.linalg.norm(r.reference[0] - r.speech_image[0]) > 0.1 * np.linalg.norm(r.reference[0])


def test_room_early50_reference_is_the_rir_cut_50_ms_after_the_direct_path(speech, noise):
    scene = small_room_scene(reference="early50", max_order=6)
    images = render_images(scene, speech, [noise])
    src = scene.pair.source_position(45.0, 1.0)
    r0 = np.linalg.norm(scene.pair.positions_m[0] - src)
    h = images.rirs["speech"]
    cut = int(np.ceil((r0 / scene.room.c + 0.05) * FS))
    np.testing.assert_array_equal(images.rirs["speech_reference"], h[:1, :cut])
    expected = sps.fftconvolve(speech, h[0, :cut])[:N]
    np.testing.assert_allclose(images.reference[0], expected, atol=1e-9 * np.abs(expected).max())


def test_room_with_diffuse_noise_and_point_noise(speech, noise):
    scene = small_room_scene(noises=(NoiseSource(field="diffuse"), NoiseSource(azimuth_deg=200.0)))
    images = render_images(scene, speech, [None, noise])
    assert set(images.rirs) == {"speech", "speech_reference", "noise1"}
    assert np.all(np.isfinite(images.noise_image))


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: small_room_scene(speech=SourcePlacement(distance_m=5.0)), "speech.position_m"),
        (lambda: small_room_scene(pair=MicPair(center_m=(9.0, 1.0, 1.0))), "pair.center_m"),
        (
            lambda: small_room_scene(noises=(NoiseSource(distance_m=3.0),)),
            r"noises\[0\].position_m",
        ),
        (lambda: NoiseSource(field="babble"), "field"),
        (lambda: SourcePlacement(distance_m=-1.0), "distance_m"),
        (lambda: SourcePlacement(elevation_deg=95.0), "elevation_deg"),
        (lambda: SourcePlacement(position_m=(1.0, 2.0)), "position_m"),
        (lambda: Scene(snr_mode="peak"), "snr_mode"),
        (lambda: Scene(reference="late"), "reference"),
        (lambda: Scene(seed=-1), "seed"),
        (lambda: Scene(fs=0), "fs"),
        (lambda: Scene(pair=0.0214), "pair"),
        (lambda: Scene(room="big"), "room"),
        (lambda: Scene(noises=NoiseSource()), "noises"),
        (lambda: Scene(snr_db=float("nan")), "snr_db"),
        (lambda: Scene(max_order=-1), "max_order"),
        (
            lambda: Scene(far_field=False, speech=SourcePlacement(position_m=(0.0107, 0.0, 0.0))),
            "speech.position_m",
        ),
    ],
)
def test_bad_scene_raises_naming_the_parameter(make, name):
    with pytest.raises(ParameterError, match=name):
        make()


def test_bad_signals_raise_naming_the_parameter(speech, noise):
    with pytest.raises(ParameterError, match=r"noise_signals\[0\]"):
        render_images(Scene(), speech, [noise[: N - 1]])
    with pytest.raises(ParameterError, match=r"noise_signals\[0\]"):
        render_images(Scene(), speech, [np.ones((2, N))])  # a point source needs a mono signal
    with pytest.raises(ParameterError, match=r"noise_signals\[0\]"):
        render_images(Scene(noises=(NoiseSource(field="diffuse"),)), speech, [np.ones((3, N))])
    with pytest.raises(ParameterError, match="noise_signals"):
        render_images(Scene(), speech, [])
    with pytest.raises(ParameterError, match="speech"):
        render_images(Scene(), np.zeros(N), [noise])
    with pytest.raises(ParameterError, match="speech"):
        render_images(Scene(), np.ones((2, N)), [noise])
    with pytest.raises(ParameterError, match="snr_db"):
        render_images(Scene(), speech, [noise]).mix(float("inf"))
    with pytest.raises(ParameterError, match="noise_signals"):
        render_images(Scene(), speech, [np.zeros(N)]).mix(0.0)


# ------------------------------------------------------------------ RIR cache
def test_cached_rir_memory_and_disk(tmp_path):
    room = ShoeBox((4.0, 3.5, 2.8), absorption=0.5)
    src, mics = (1.0, 1.0, 1.0), np.array([[2.0, 2.0, 1.5], [2.1, 2.0, 1.5]])
    cache.clear_memory_cache()
    h1 = cache.cached_rir(room, src, mics, fs=FS, max_order=2, cache_dir=tmp_path)
    # Oracle: the ISM called directly (bit-identical: the cache stores what it computed), with the
    # 20 Hz high-pass room_rir applies by default.
    np.testing.assert_array_equal(h1, image_source_rir(room, src, mics, fs=FS, max_order=2, highpass_hz=20.0))
    files = list(tmp_path.iterdir())
    assert len(files) == 1 and files[0].suffix == ".npy"  # no temporary file left behind
    h1[:] = 0.0  # the caller's copy; the cache is untouched
    cache.clear_memory_cache()
    h2 = cache.cached_rir(room, src, mics, fs=FS, max_order=2, cache_dir=tmp_path)  # from disk
    np.testing.assert_array_equal(h2, image_source_rir(room, src, mics, fs=FS, max_order=2, highpass_hz=20.0))
    assert cache.memory_cache_size() == 1
    files[0].write_bytes(b"torn")  # an unreadable file is recomputed and replaced
    cache.clear_memory_cache()
    h3 = cache.cached_rir(room, src, mics, fs=FS, max_order=2, cache_dir=tmp_path)
    np.testing.assert_array_equal(h3, h2)
    np.testing.assert_array_equal(np.load(files[0]), h2)


def test_rir_key_depends_on_every_parameter():
    room = ShoeBox((4.0, 3.5, 2.8), absorption=0.5)
    mics = [[2.0, 2.0, 1.5]]
    base = cache.rir_key(room, (1, 1, 1), mics, fs=FS, max_order=2)
    assert base == cache.rir_key(room, (1.0, 1.0, 1.0), np.array(mics), fs=FS, max_order=2)
    others = {
        cache.rir_key(
            ShoeBox((4.0, 3.5, 2.8), absorption=0.4), (1, 1, 1), mics, fs=FS, max_order=2
        ),
        cache.rir_key(room, (1, 1, 1.1), mics, fs=FS, max_order=2),
        cache.rir_key(room, (1, 1, 1), [[2.0, 2.0, 1.4]], fs=FS, max_order=2),
        cache.rir_key(room, (1, 1, 1), mics, fs=8000, max_order=2),
        cache.rir_key(room, (1, 1, 1), mics, fs=FS, max_order=3),
        cache.rir_key(room, (1, 1, 1), mics, fs=FS, max_order=2, reflection_sign=-1.0),
    }
    assert base not in others and len(others) == 6
