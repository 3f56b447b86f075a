"""Image-source RIRs: the vectorised renderers against a slow loop reference and physical laws."""

from __future__ import annotations

import math

import numpy as np
import pytest
from ism_reference import reference_rir
from scipy import signal

from scenesim.errors import ParameterError
from scenesim.room.ism import (
    SINC_HALF_WIDTH,
    image_count_l1,
    image_source_rir,
    image_sources,
    windowed_sinc,
)
from scenesim.room.shoebox import ShoeBox

PER_WALL = (0.12, 0.35, 0.5, 0.21, 0.7, 0.05)


def _rel_l2(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize(
    ("dims", "absorption", "src", "mics", "order", "fs", "sign"),
    [
        ((4.0, 3.5, 2.7), PER_WALL, (1.1, 2.3, 1.2), ((3.2, 0.9, 1.6), (3.2214, 0.9, 1.6)), 3, 16000, 1.0),
        ((6.0, 5.0, 3.0), 0.3, (5.1, 0.4, 2.2), ((0.7, 4.1, 0.5),), 2, 8000, -1.0),
        ((2.5, 7.0, 3.3), PER_WALL[::-1], (0.3, 6.2, 0.4), ((2.1, 0.5, 2.9),), 4, 16000, 1.0),
    ],
)
def test_exact_equals_slow_loop_reference(dims, absorption, src, mics, order, fs, sign):
    """Oracle: tests/ism_reference.py (triple loop, scalar sinc). Tolerance 1e-10 of the peak:
    both evaluate the same formula, only the summation order and sin/cos routines differ."""
    room = ShoeBox(dims, absorption)
    ours = image_source_rir(
        room, src, mics, fs=fs, max_order=order, method="exact", reflection_sign=sign
    )
    for m, mic in enumerate(mics):
        ref = reference_rir(
            dims, room.wall_absorption, src, mic, fs=fs, max_order=order,
            n_taps=ours.shape[1], sign=sign,
        )
        np.testing.assert_allclose(ours[m], ref, rtol=0, atol=1e-10 * np.abs(ref).max())


@pytest.mark.parametrize(
    ("dims", "absorption", "kwargs"),
    [
        ((6.0, 5.0, 3.0), PER_WALL, {"max_order": 10}),
        ((4.0, 3.5, 2.7), 0.25, {"length_s": 0.25}),
        ((3.0, 2.2, 2.4), 0.4, {"max_order": 6, "reflection_sign": -1.0}),
    ],
)
def test_fast_matches_exact(dims, absorption, kwargs):
    """Oracle: the exact renderer (itself checked against the loop reference).
    The fast renderer cubic-interpolates the same kernel on a 16x grid: per-image error
    <= ~0.46/16^4 = 7e-6 of the image's peak; measured ~7e-6 relative L2.
    Tolerance: 3e-5 relative L2 and 3e-5 of the peak per tap."""
    room = ShoeBox(dims, absorption)
    src = np.asarray(dims) * [0.3, 0.6, 0.4]
    mics = np.asarray(dims) * [[0.7, 0.3, 0.55], [0.69, 0.31, 0.55]]
    exact = image_source_rir(room, src, mics, fs=16000, method="exact", **kwargs)
    fast = image_source_rir(room, src, mics, fs=16000, method="fast", **kwargs)
    assert exact.shape == fast.shape
    for m in range(2):
        assert _rel_l2(fast[m], exact[m]) < 3e-5
    np.testing.assert_allclose(fast, exact, rtol=0, atol=3e-5 * np.abs(exact).max())


def test_direct_path_amplitude_and_arrival():
    """Physical law: a free-field point source gives 1/(4 pi r) at t = r/c.
    With max_order=0 and c chosen so r fs / c is an integer D, the band-limited impulse
    is exactly a/(4 pi r) at tap D and (sinc zeros) 0 elsewhere: tolerance 1e-12 of the peak."""
    room = ShoeBox((6.0, 5.0, 3.0), 0.5)
    src, mic = np.array([1.0, 1.5, 1.2]), np.array([4.3, 3.1, 1.7])
    r = float(np.linalg.norm(mic - src))
    fs = 16000
    d = 160  # c = r fs / 160 ~ 370 m/s
    h = image_source_rir(room, src, mic, fs=fs, max_order=0, c=r * fs / d, method="exact")[0]
    expected = np.zeros_like(h)
    expected[d] = 1.0 / (4.0 * np.pi * r)
    np.testing.assert_allclose(h, expected, rtol=0, atol=1e-12 * expected[d])


def test_direct_path_fractional_delay_anechoic():
    """Anechoic room (absorption 1 on every wall, default length): the RIR is the direct path only.
    Oracles: arrival r/c (peak at the nearest tap), area = 1/(4 pi r) (windowed sinc DC gain,
    |1 - sum| < 1e-3 for the 80-tap Hann kernel), and the exact windowed sinc shape (1e-12)."""
    room = ShoeBox((6.0, 5.0, 3.0), 1.0)
    src, mic = np.array([1.0, 1.5, 1.2]), np.array([4.3, 3.1, 1.7])
    r = float(np.linalg.norm(mic - src))
    fs = 16000
    delay = r * fs / 343.0
    h = image_source_rir(room, src, mic, fs=fs, method="exact")[0]
    a = 1.0 / (4.0 * np.pi * r)
    assert int(np.argmax(h)) == round(delay)
    assert abs(h.sum() / a - 1.0) < 1e-3
    np.testing.assert_allclose(h, a * windowed_sinc(np.arange(h.size) - delay), rtol=0, atol=1e-12 * a)


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_reciprocity(method):
    """Physical law (reciprocity; for the ISM exact by the image lattice's symmetry):
    swapping source and mic gives the same RIR. Tolerance 1e-12 relative (rounding only)."""
    room = ShoeBox((5.0, 4.0, 3.0), PER_WALL)
    a, b = (1.2, 0.8, 2.1), (3.9, 2.7, 0.6)
    h_ab = image_source_rir(room, a, b, fs=16000, max_order=12, method=method)
    h_ba = image_source_rir(room, b, a, fs=16000, max_order=12, method=method)
    np.testing.assert_allclose(h_ab, h_ba, rtol=0, atol=1e-12 * np.abs(h_ab).max())


@pytest.mark.parametrize("n", range(7))
def test_image_count_l1(n):
    """Oracle: the lattice-point count of the L1 ball 1 + 2N(2N^2 + 3N + 4)/3 and a brute-force set."""
    room = ShoeBox((4.0, 3.0, 2.5), 0.3)
    idx, pos, gains = image_sources(room, (1.0, 1.0, 1.0), max_order=n)
    assert len(idx) == image_count_l1(n) == 1 + 2 * n * (2 * n * n + 3 * n + 4) // 3
    brute = {
        (i, j, k)
        for i in range(-n, n + 1)
        for j in range(-n, n + 1)
        for k in range(-n, n + 1)
        if abs(i) + abs(j) + abs(k) <= n
    }
    assert set(map(tuple, idx.tolist())) == brute
    assert pos.shape == (len(idx), 3) and gains.shape == (len(idx),)


def test_mirror_symmetry_per_wall_gains():
    """Per-wall gains: swapping the x=0 and x=Lx absorptions and mirroring x -> Lx - x gives the
    identical RIR (oracle: geometry). Tolerance 1e-12 of the peak."""
    dims = (5.0, 4.0, 3.0)
    alpha = np.array(PER_WALL)
    swapped = alpha[[1, 0, 2, 3, 4, 5]]
    src, mic = np.array([1.2, 0.8, 2.1]), np.array([3.9, 2.7, 0.6])
    mirror = np.array([dims[0], 0, 0])
    flip = np.array([-1.0, 1.0, 1.0])
    h1 = image_source_rir(ShoeBox(dims, tuple(alpha)), src, mic, fs=16000, max_order=10, method="exact")
    h2 = image_source_rir(
        ShoeBox(dims, tuple(swapped)), mirror + flip * src, mirror + flip * mic, fs=16000,
        max_order=10, method="exact",
    )
    np.testing.assert_allclose(h1, h2, rtol=0, atol=1e-12 * np.abs(h1).max())
    # And the swap really matters (the walls differ): not the same RIR without mirroring.
    h3 = image_source_rir(ShoeBox(dims, tuple(swapped)), src, mic, fs=16000, max_order=10, method="exact")
    assert _rel_l2(h3, h1) > 1e-2


def test_first_order_reflection_scales_with_wall_reflection():
    """Per-wall gain law b = sqrt(1 - alpha): with max_order=1 and every other wall anechoic,
    the x=0 reflection (RIR minus direct path) scales by sqrt(1-0.19)/sqrt(1-0.64) = 1.5.
    Tolerance 1e-12 of the peak (linearity of the renderer)."""
    dims, src, mic = (5.0, 4.0, 3.0), (1.0, 2.0, 1.5), (2.5, 2.2, 1.4)
    direct = image_source_rir(ShoeBox(dims, 1.0), src, mic, fs=16000, max_order=1, length_s=0.05)

    def reflection(alpha0):
        room = ShoeBox(dims, (alpha0, 1.0, 1.0, 1.0, 1.0, 1.0))
        return image_source_rir(room, src, mic, fs=16000, max_order=1, length_s=0.05) - direct

    r1, r2 = reflection(0.19), reflection(0.64)
    np.testing.assert_allclose(r1, 1.5 * r2, rtol=0, atol=1e-12 * np.abs(r1).max())
    # The reflection arrives at the image distance |(-s_x, s_y, s_z) - mic| / c.
    r_img = math.dist((-src[0], src[1], src[2]), mic)
    assert int(np.argmax(np.abs(r1))) == round(r_img * 16000 / 343.0)


def test_reflection_sign_flips_odd_orders():
    """sign = -1 multiplies each image by (-1)^order: with max_order=1, h(+1) + h(-1) is twice
    the direct path (order 0). Oracle: the max_order=0 RIR; tolerance 1e-12 of the peak."""
    room = ShoeBox((5.0, 4.0, 3.0), 0.3)
    src, mic = (1.0, 2.0, 1.5), (3.5, 1.2, 2.0)
    kw = {"fs": 16000, "max_order": 1, "length_s": 0.06}
    plus = image_source_rir(room, src, mic, reflection_sign=1.0, **kw)
    minus = image_source_rir(room, src, mic, reflection_sign=-1.0, **kw)
    direct = image_source_rir(room, src, mic, fs=16000, max_order=0, length_s=0.06)
    np.testing.assert_allclose(plus + minus, 2 * direct, rtol=0, atol=1e-12 * np.abs(plus).max())
    assert _rel_l2(plus, minus) > 0.1


def test_all_images_within_length_equals_large_order_truncated():
    """max_order=None keeps every image arriving within the length; the L1 set with an order
    large enough to contain that sphere, truncated to the same length, must give the same RIR.
    Oracle: the L1 enumeration (checked against the loop reference). Tolerance 1e-12 of the peak."""
    room = ShoeBox((3.0, 2.5, 2.2), 0.2)
    src, mic = (0.7, 1.9, 1.1), (2.2, 0.6, 0.8)
    fs, length_s = 8000, 0.06
    radius = (math.ceil(length_s * fs) - 1 + SINC_HALF_WIDTH) * 343.0 / fs
    big_order = 3 * (math.ceil(radius / 2.2) + 1)
    by_radius = image_source_rir(room, src, mic, fs=fs, length_s=length_s, method="exact")
    by_order = image_source_rir(room, src, mic, fs=fs, length_s=length_s, max_order=big_order, method="exact")
    assert by_radius.shape == (1, math.ceil(length_s * fs))
    np.testing.assert_allclose(by_radius, by_order, rtol=0, atol=1e-12 * np.abs(by_order).max())


def test_default_length_and_shapes():
    """Documented default: ceil((1.2 x nominal RT60 + longest direct path) fs) taps; (3,) mic -> 1 row."""
    room = ShoeBox((4.0, 3.0, 2.5), rt60_s=0.3)
    src, mic = np.array([1.0, 1.0, 1.0]), np.array([3.0, 2.0, 1.5])
    h = image_source_rir(room, src, mic, fs=8000)
    expected = math.ceil((1.2 * 0.3 + np.linalg.norm(mic - src) / 343.0) * 8000)
    assert h.shape == (1, expected)
    assert h.dtype == np.float64


def test_highpass_is_causal_butterworth():
    """Oracle: scipy's causal 2nd-order Butterworth high-pass applied to the unfiltered RIR (1e-12)."""
    room = ShoeBox((4.0, 3.0, 2.5), 0.3)
    kw = {"fs": 16000, "max_order": 5}
    raw = image_source_rir(room, (1, 1, 1), (3, 2, 1.5), **kw)
    hp = image_source_rir(room, (1, 1, 1), (3, 2, 1.5), highpass_hz=100.0, **kw)
    sos = signal.butter(2, 100.0, btype="highpass", fs=16000, output="sos")
    np.testing.assert_allclose(hp, signal.sosfilt(sos, raw, axis=-1), rtol=0, atol=1e-12 * np.abs(raw).max())


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"fs": 0}, "fs"),
        ({"fs": 16000.5}, "fs"),
        ({"fs": 16000, "method": "magic"}, "method"),
        ({"fs": 16000, "max_order": -1}, "max_order"),
        ({"fs": 16000, "max_order": 2.5}, "max_order"),
        ({"fs": 16000, "length_s": 0.0}, "length_s"),
        ({"fs": 16000, "reflection_sign": 0.5}, "reflection_sign"),
        ({"fs": 16000, "highpass_hz": 9000.0}, "highpass_hz"),
        ({"fs": 16000, "c": -1.0}, "c"),
    ],
)
def test_bad_settings_raise(kwargs, name):
    room = ShoeBox((4.0, 3.0, 2.5), 0.3)
    with pytest.raises(ParameterError, match=name):
        image_source_rir(room, (1, 1, 1), (3, 2, 1.5), **kwargs)


@pytest.mark.parametrize(
    ("src", "mics", "name"),
    [
        ((5.0, 1.0, 1.0), (3, 2, 1.5), "source_m"),
        ((0.05, 1.0, 1.0), (3, 2, 1.5), "source_m"),
        ((1, 1), (3, 2, 1.5), "source_m"),
        ((1, 1, 1), (3, 2, 2.45), "mics_m"),
        ((1, 1, 1), ((3, 2, 1.5), (3, 2, 9.0)), "mics_m"),
        ((1, 1, 1), np.zeros((2, 2)), "mics_m"),
    ],
)
def test_positions_outside_raise(src, mics, name):
    room = ShoeBox((4.0, 3.0, 2.5), 0.3)
    with pytest.raises(ParameterError, match=name):
        image_source_rir(room, src, mics, fs=16000)


def test_room_type_checked():
    with pytest.raises(ParameterError, match="room"):
        image_source_rir((4, 3, 2.5), (1, 1, 1), (3, 2, 1.5), fs=16000)


@pytest.mark.parametrize("method", ["exact", "fast"])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_swapping_the_two_walls_of_any_axis_mirrors_the_room(axis, method):
    """Geometry: swapping the two absorptions of one axis and mirroring that coordinate
    (u -> L - u) gives the identical RIR, for every axis (a wall-index slip on y or z fails).
    Tolerance 1e-12 of the peak."""
    dims = np.array([5.0, 4.0, 3.0])
    alpha = np.array(PER_WALL)
    order = [0, 1, 2, 3, 4, 5]
    order[2 * axis], order[2 * axis + 1] = order[2 * axis + 1], order[2 * axis]
    src, mic = np.array([1.2, 0.8, 2.1]), np.array([3.9, 2.7, 0.6])
    flip = np.ones(3)
    flip[axis] = -1.0
    shift = np.where(flip < 0, dims, 0.0)
    h1 = image_source_rir(ShoeBox(tuple(dims), tuple(alpha)), src, mic, fs=16000, max_order=10, method=method)
    h2 = image_source_rir(ShoeBox(tuple(dims), tuple(alpha[order])), shift + flip * src, shift + flip * mic,
                          fs=16000, max_order=10, method=method)
    np.testing.assert_allclose(h1, h2, rtol=0, atol=1e-12 * np.abs(h1).max())


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_permuting_the_axes_permutes_nothing_in_the_rir(method):
    """Geometry: relabelling the axes (x, y, z) -> (y, z, x) in the dimensions, the per-wall
    absorptions and both positions describes the same room: the same RIR (1e-12 of the peak)."""
    perm = [1, 2, 0]
    dims = np.array([5.0, 4.0, 3.0])
    alpha = np.array(PER_WALL).reshape(3, 2)
    src, mic = np.array([1.2, 0.8, 2.1]), np.array([3.9, 2.7, 0.6])
    h1 = image_source_rir(ShoeBox(tuple(dims), tuple(alpha.ravel())), src, mic, fs=16000, max_order=10,
                          method=method)
    h2 = image_source_rir(ShoeBox(tuple(dims[perm]), tuple(alpha[perm].ravel())), src[perm], mic[perm],
                          fs=16000, max_order=10, method=method)
    np.testing.assert_allclose(h1, h2, rtol=0, atol=1e-12 * np.abs(h1).max())
