"""Diffuse (scattered) reflections: the energy model against closed forms, and the calibrated
rooms against the issue's targets in rooms the calibration never saw."""

import math

import numpy as np
import pytest

from scenesim.room.calibration import calibrate_room
from scenesim.room.iso3382 import diffuse_field_parameters, room_parameters
from scenesim.room.render import room_rir
from scenesim.room.rt60 import eyring_rt60
from scenesim.room.scattering import scattered_energy
from scenesim.room.shoebox import ShoeBox

FS = 8000
C = 343.0


def _specular_level(dims, reflection, scattering, t):
    """The specular field's expected h^2 summed over directions (the model's own e_s, closed form)."""
    from scenesim.room.hybrid import _octant_directions
    from scenesim.room.scattering import _N_DIR

    u, w = _octant_directions(_N_DIR, _N_DIR)
    keep = np.asarray(reflection) ** 2 * (1 - np.asarray(scattering))
    loss = -0.5 * (np.log(keep[0::2]) + np.log(keep[1::2]))
    mu = (C * u / np.asarray(dims)) @ loss
    return C / (4 * np.pi * np.prod(dims) * FS) * np.sum(w * np.exp(-mu * t))


def test_energy_is_conserved_without_absorption():
    """Oracle: energy conservation.  With no absorption, what the specular field loses to
    scattering the scattered field gains: specular + scattered = the initial level at every
    time (1e-4: the injection is linear within each 0.5 ms step; measured 7e-6)."""
    dims, s = (7.0, 4.0, 3.0), np.array([0.2, 0.5, 0.3, 0.3, 0.1, 0.6])
    refl = np.ones(6)
    e = scattered_energy(dims, refl[None], s[None], int(0.6 * FS), fs=FS, c=C, t0_s=0.0)[0]
    level = C / (4 * np.pi * np.prod(dims) * FS)
    for t in (0.05, 0.2, 0.5):
        total = e[int(t * FS)] + _specular_level(dims, refl, s, int(t * FS) / FS)
        assert total == pytest.approx(level, rel=1e-4)


@pytest.mark.parametrize("alpha", [0.1, 0.4])
def test_isotropic_scattered_field_decays_at_eyrings_rate(alpha):
    """Oracle: Eyring's formula.  Nearly total Lambert scattering (s = 0.99) keeps the scattered
    field isotropic, which meets c S / (4 V) walls per second and keeps (1 - alpha) per hit: its
    late decay is Eyring's T = 24 ln10 V / (-c S ln(1 - alpha)) (0.5 %: the residual
    anisotropy at s < 1 and the 144-direction quadrature; measured +0.08 / +0.42 %)."""
    dims = (6.0, 5.0, 3.0)
    refl = np.full((1, 6), math.sqrt(1 - alpha))
    t_ey = eyring_rt60(dims, alpha, c=C)
    e = scattered_energy(dims, refl, np.full((1, 6), 0.99), int(1.5 * t_ey * FS), fs=FS, c=C, t0_s=0.0)[0]
    i0, i1 = int(0.3 * t_ey * FS), int(1.2 * t_ey * FS)
    slope = np.polyfit(np.arange(i0, i1) / FS, 10 * np.log10(e[i0:i1]), 1)[0]
    assert -60.0 / slope == pytest.approx(t_ey, rel=5e-3)


def test_no_scattering_is_the_specular_ism():
    room = ShoeBox((5.0, 4.0, 3.0), 0.3)
    same = ShoeBox((5.0, 4.0, 3.0), 0.3, scattering=0.0)
    assert same.scattering is None
    a = room_rir(room, (1, 1, 1.5), (4, 3, 1.4), fs=FS, length_s=0.2)
    b = room_rir(same, (1, 1, 1.5), (4, 3, 1.4), fs=FS, length_s=0.2)
    np.testing.assert_array_equal(a, b)


def test_scattering_keeps_the_early_specular_part_exact():
    """Before the direct sound nothing; the specular images are the ISM's with sqrt((1-a)(1-s))
    reflections: subtracting that ISM leaves only the scattered noise, whose energy over the
    first 50 ms after the direct sound is the model's (within 25 %: 400 noise samples)."""
    dims, alpha, s = (6.0, 5.0, 3.0), 0.3, 0.5
    src, mic = np.array([1.2, 1.1, 1.5]), np.array([4.5, 3.2, 1.3])
    h = room_rir(ShoeBox(dims, alpha, scattering=s), src, mic, fs=FS, length_s=0.3, highpass_hz=None)[0]
    spec = room_rir(ShoeBox(dims, 1 - (1 - alpha) * (1 - s)), src, mic, fs=FS, length_s=0.3, highpass_hz=None)[0]
    rest = h - spec
    n0 = int(np.ceil(np.linalg.norm(src - mic) / C * FS))
    assert np.max(np.abs(rest[:n0])) == 0.0
    model = scattered_energy(dims, np.full((1, 6), math.sqrt(1 - alpha)), np.full((1, 6), s), h.size, fs=FS, c=C,
                             t0_s=np.linalg.norm(src - mic) / C)[0]
    win = slice(n0, n0 + int(0.05 * FS))
    assert np.sum(rest[win] ** 2) == pytest.approx(np.sum(model[win]), rel=0.25)


def test_banded_image_source_render_honours_scattering():
    """Oracle: the broadband renderer of each band's own room.  ``image_source_rir_bands`` of a
    scattered room with two bands of different absorption is, band by band, ``image_source_rir``
    of the flat room with that band's absorption, the same scattering and seed (specular images
    with sqrt((1-a)(1-s)) + that band's scattered field), and its band merge is the broadband
    renderer's with ``bands_hz``.  Tolerance 1e-12 of the peak (the same arithmetic)."""
    from scenesim.room.ism import image_source_rir, image_source_rir_bands
    from scenesim.room.ism_bands import merge_bands

    dims, s, alphas, bands = (5.0, 4.0, 3.0), 0.4, (0.2, 0.5), (500.0, 2000.0)
    src, mics = (1.2, 1.1, 1.5), ((4.0, 3.0, 1.4), (4.02, 3.0, 1.4))
    refl = np.sqrt(1.0 - np.array(alphas))[:, None] * np.ones((1, 6))
    kw = {"fs": FS, "length_s": 0.3, "method": "fast", "seed": 7}
    h = image_source_rir_bands(ShoeBox(dims, alphas[0], scattering=s), src, mics, n_bands=2,
                               reflection_bands=refl, **kw)
    for b, alpha in enumerate(alphas):
        ref = image_source_rir(ShoeBox(dims, alpha, scattering=s), src, mics, **kw)
        np.testing.assert_allclose(h[b], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    broadband = image_source_rir(ShoeBox(dims, alphas[0], scattering=s), src, mics, reflection_bands=refl,
                                 bands_hz=bands, **kw)
    np.testing.assert_allclose(merge_bands(h, FS, bands), broadband, rtol=0, atol=1e-12 * np.abs(broadband).max())


ROOMS = {  # rooms the calibration never saw, with placements drawn independently of its own
    "corridor": ((14.0, 2.2, 2.8), 0.8, None),
    "absorptive wall": ((7.0, 5.0, 3.0), 0.5, (0.9, 0.1, 0.1, 0.1, 0.1, 0.1)),
    "open office": ((16.0, 12.0, 2.9), 0.6, (0.15, 0.15, 0.15, 0.15, 0.1, 0.6)),
}


@pytest.mark.parametrize("name", list(ROOMS))
def test_calibrated_rooms_sound_like_their_rt60(name):
    """The issue's targets with the defaults (scattering 0.5): at two placements the loop never
    used, speech-octave (500 Hz-2 kHz) T30 within 10 % of the target, EDT within 20 %, C50 within
    2 dB of Sabine's diffuse-field value (ISO 3382 definitions, scenesim.room.iso3382).  Without
    scattering the same rooms missed EDT by 29-60 % (issue 18)."""
    dims, target, profile = ROOMS[name]
    room = calibrate_room(dims, target, absorption=profile)
    rng = np.random.default_rng(11)
    d = np.asarray(dims)
    for _ in range(2):
        src, mic = rng.uniform(0.15, 0.85, 3) * d, rng.uniform(0.15, 0.85, 3) * d
        src[2], mic[2] = 1.6, 1.0
        h = room_rir(room, src, mic, fs=16000)[0]
        hd = room_rir(room, src, mic, fs=16000, max_order=0, length_s=h.size / 16000)[0]
        got = room_parameters(h, 16000, h_direct=hd, centers_hz=(500.0, 1000.0, 2000.0))
        want = diffuse_field_parameters(target, float(np.linalg.norm(src - mic)), float(np.prod(d)))
        assert got["t_speech_s"] == pytest.approx(target, rel=0.10)
        assert got["edt_speech_s"] == pytest.approx(target, rel=0.20)
        assert got["c50_db"] == pytest.approx(want["c50_db"], abs=2.0)


def test_against_pyroomacoustics_ray_tracing_in_a_near_diffuse_room():
    """Outside oracle: pyroomacoustics' hybrid ray tracer (ISM order 3 + 20000 rays) with the same
    absorption (0.19) and scattering (0.5) in a near-diffuse 8 x 6 x 3 m room: per-octave T30
    (250 Hz-4 kHz) within 10 % and the speech-octave mean EDT within 20 % (its rays seeded:
    measured T30 -3..+5 %, speech EDT +8 %; one placement's octave EDT scatters more).  Not used
    in corridors: there its scattered energy,
    not re-traced (pyroomacoustics issue #415), makes it decay faster than Eyring."""
    from scenesim.room.crosscheck_scattering import compare_scattering_with_pyroomacoustics

    room = ShoeBox((8.0, 6.0, 3.0), 0.19, scattering=0.5)
    chk = compare_scattering_with_pyroomacoustics(room, (1.0, 1.5, 1.5), [(5.0, 3.5, 1.4)], fs=16000)
    np.testing.assert_allclose(chk.t30_ours_s, chk.t30_theirs_s, rtol=0.10)
    assert np.mean(chk.edt_ours_s[1:4]) == pytest.approx(np.mean(chk.edt_theirs_s[1:4]), rel=0.20)


def test_a_scattering_room_is_reciprocal_between_source_and_receiver():
    """Reciprocity (a physical law of a linear, motionless room): swapping an omni source and an omni
    receiver leaves the RIR unchanged; the scattered tail's random draw included (tolerance: float
    rounding of the image distances, 1e-6 of the peak)."""
    import scenesim

    room = scenesim.calibrate_room((6, 4, 3), 0.6)
    assert room.scattering is not None
    a = scenesim.image_source_rir(room, (1.2, 1.1, 1.4), [(4.3, 2.6, 1.5)], fs=16000)
    b = scenesim.image_source_rir(room, (4.3, 2.6, 1.5), [(1.2, 1.1, 1.4)], fs=16000)
    np.testing.assert_allclose(b, a, atol=1e-6 * np.abs(a).max())


def test_max_order_bounds_the_specular_part_and_scattering_zero_the_rest():
    """As documented: in a scattering room max_order 1 keeps the scattered tail (T30 near the full RIR's);
    with scattering 0 the same order leaves almost nothing after the first reflections."""
    import scenesim
    from scenesim.room.rt60 import measure_rt60
    from scenesim.room.shoebox import ShoeBox

    room = scenesim.calibrate_room((6, 4, 3), 0.6)
    kw = dict(fs=16000, length_s=0.6)
    full = scenesim.image_source_rir(room, (1.2, 1.1, 1.4), [(4.3, 2.6, 1.5)], **kw)
    low = scenesim.image_source_rir(room, (1.2, 1.1, 1.4), [(4.3, 2.6, 1.5)], max_order=1, **kw)
    t_full, t_low = (float(np.mean(measure_rt60(h, 16000, method="T30"))) for h in (full, low))
    assert abs(t_low / t_full - 1) < 0.02  # measured 1.0002: the tail decides T30, not the images
    specular = ShoeBox(dims_m=room.dims_m, absorption=room.wall_absorption.tolist(), scattering=0.0)
    h = scenesim.image_source_rir(specular, (1.2, 1.1, 1.4), [(4.3, 2.6, 1.5)], max_order=1, **kw)
    late = slice(int(0.1 * 16000), None)  # after the first reflections (the last order-1 image: ~30 ms)
    assert np.sum(h[0, late] ** 2) < 1e-6 * np.sum(h**2)
