"""Image-source method for shoebox rooms (Allen & Berkley 1979; Peterson 1986; algorithms.md section 3).

Image ``(i, j, k)`` in Z^3; per axis with index ``i``, source coordinate ``s``, length ``L``::

    x = i L + s (i even) | i L + L - s (i odd)
    n = |i|, n0 = floor(n/2) if i > 0 else ceil(n/2), nL = n - n0      (hits on wall 0 / wall L)
    g = prod_axes b0^n0 bL^nL * sign^n,   b = sqrt(1 - alpha)
    r = |x_img - x_mic|,  delay D = r fs / c samples,  amplitude a = g / (4 pi r)

The RIR is ``h[n] = sum_images a * w(n - D) * sinc(n - D)`` with a Hann window
``w(t) = 0.5 (1 + cos(pi t / T))`` for ``|t| < T``, ``T =`` :data:`SINC_HALF_WIDTH` = 40
samples (the 81-tap footprint pyroomacoustics uses), centred on the true delay (Peterson).

Time origin: tap 0 is the instant of emission and there is **no global offset** (unlike
pyroomacoustics' 40 samples), so the direct path's band-limited peak sits at ``r fs / c``.
The left half of a sinc that would fall before t = 0 is truncated at tap 0; for a
source-mic distance of d metres that loses the taps of the first ``d fs / c`` < 40 samples'
worth of the kernel's left tail (negligible energy beyond a few samples).

Everything is separable per axis: squared distances are ``dx^2[i] + dy^2[j] + dz^2[k]`` and
gains ``gx[i] gy[j] gz[k]``.  The ``(j, k)`` pairs are precomputed once, sorted by a key
(L1 order, or the smallest squared distance over the mics) so that each ``i`` slice takes a
prefix; images are rendered in bounded chunks, so memory does not grow with the image count.

Renderers:

* ``"exact"``: the windowed-sinc sum above, vectorised over images and taps in chunks of
  :data:`_EXACT_CHUNK` images (memory bounded: ~45 MiB peak whatever the image count; it
  grew with RT60^2 before, 1.26 GiB at 2 s); equals the scalar triple-loop reference in
  ``tests/ism_reference.py`` to 1e-10.  Pure numpy: the reference the fast path is tested
  against.
* ``"fast"``: each image's amplitude is scattered onto a time grid oversampled by
  :data:`FAST_OVERSAMPLING` with 4-point (cubic) Lagrange weights by a compiled loop
  (:mod:`scenesim.room.ism_kernels`, numba), then the grid is filtered by the same windowed sinc
  sampled at the fine rate and decimated by U (polyphase: U branch convolutions done as
  float32 FFTs, which beat ``scipy.signal.upfirdn``'s direct polyphase loop by ~5x at these
  lengths).  This equals the exact sum with the kernel cubic-interpolated between fine-grid
  points: interpolation error <= ~0.46 / U^4 of the peak (U = 16: ~7e-6); measured against
  ``"exact"``: relative L2 error 4e-6..7e-6 (``tests/test_ism.py`` asserts 3e-5).  Cost per
  image is O(1), independent of the kernel length; images arriving after the last tap are
  pruned.  Memory: the grid, n_bands x n_mics x ~16 n_taps float64.
* ``"hybrid"``: the images reaching taps before the mixing time, rendered by ``"fast"`` (so
  those taps equal the full ``"fast"`` RIR's), then a seeded stochastic tail with the ISM's
  expected per-band energy decay, each octave decaying as the room's modes there (Weyl's
  plane and axis modes), and the diffuse-field coherence between the mics, level matched to
  the early part (:mod:`scenesim.room.hybrid`); 40-tap power-complementary crossfade.

``method="auto"`` uses ``"exact"`` for small image sets (<= :data:`AUTO_EXACT_MAX_TERMS`
image-mic terms) and ``"fast"`` otherwise.

Frequency-dependent gains (source directivity, :mod:`scenesim.room.directivity`; per-band wall
reflections via :func:`image_source_rir_bands`) render one RIR per band in the same pass
over the images -- each image's emission direction is the image-to-mic direction with the
components of the oddly-reflected axes reversed -- and merge the bands with zero-phase
complementary filters (:mod:`scenesim.room.ism_bands`).
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy import signal

from scenesim.errors import ParameterError
from scenesim.room.directivity import Directivity
from scenesim.room.ism_bands import check_bands, merge_bands
from scenesim.room.shoebox import ShoeBox
from scenesim.validate import (
    check_choice,
    check_fs,
    check_int,
    check_physical,
    check_positive,
    check_range,
)

MAX_ORDER = 300
"""Largest image order: the orders a 20 s RT60 needs in the smallest room the validator admits stay below it,
and its L1 ball already holds ~3.6e7 images (larger is a typo that would allocate past the machine)."""

SINC_HALF_WIDTH = 40
"""Half width T (samples) of the Hann-windowed sinc: support |t| < T (81-tap footprint)."""
FAST_OVERSAMPLING = 16
"""Oversampling factor U of the fast renderer's scatter grid."""
AUTO_EXACT_MAX_TERMS = 20_000
"""``method="auto"`` renders exactly when images x mics is at most this."""
DEFAULT_LENGTH_RT60_FACTOR = 1.2
"""Default RIR length: this factor x the room's nominal RT60 plus the longest direct path."""
_EXACT_CHUNK = 1 << 12  # images per exact batch: ~6 arrays of n_mics x 4096 x 80 values
METHODS = ("auto", "exact", "fast", "hybrid")
MIN_SOURCE_MIC_DISTANCE_M = 1e-3
"""A source closer than this to a mic is refused (the 1/r spreading diverges)."""
DEFAULT_MIXING_TIME_S = 0.08
"""Hybrid renderer's default end of the image-source part: past the 50 ms early/late split
of C50 and of the early-reflection target, so those stay deterministic images."""


# --------------------------------------------------------------------------- enumeration
def _axis_terms(length, s, mic, n_max, b0, b_l, sign):
    """Per-axis image terms.

    Returns indices (n,), signed offsets (n_mics, n) = (mic - image) (-1)^i -- the mic as
    seen from the image, mirrored back into the source's frame by the image's parity, so
    that offsets / r is the emission direction at the real source -- and per-band gains
    (n_bands, n) from the per-band wall reflections ``b0``, ``b_l`` (n_bands,).
    """
    i = np.arange(-n_max, n_max + 1)
    odd = i % 2 != 0
    pos = i * length + np.where(odd, length - s, s)
    off = (mic[:, None] - pos[None, :]) * np.where(odd, -1.0, 1.0)
    n = np.abs(i)
    n0 = np.where(i > 0, n // 2, (n + 1) // 2)
    gain = b0[:, None] ** n0 * b_l[:, None] ** (n - n0) * sign ** n
    return i, off, gain


@dataclass
class _Images:
    """Separable description of an image set, enumerated as per-``i`` prefixes of sorted (j, k) pairs."""

    ix: np.ndarray  # (nx,) x lattice indices
    offx: np.ndarray  # (n_mics, nx) mirrored signed offsets
    gx: np.ndarray  # (n_bands, nx)
    iy: np.ndarray
    offy: np.ndarray
    gy: np.ndarray
    iz: np.ndarray
    offz: np.ndarray
    gz: np.ndarray
    pj: np.ndarray  # (P,) positions into the y arrays of the sorted pairs
    pk: np.ndarray  # (P,) positions into the z arrays
    counts: np.ndarray  # (nx,) prefix length per x index
    r2_max: float  # largest squared distance in the set (over mics)

    @property
    def n_images(self) -> int:
        return int(self.counts.sum())

    @property
    def n_mics(self) -> int:
        return self.offx.shape[0]

    def slices(self):
        """Yield ``(x position index, prefix count)`` for every non-empty slice."""
        for a, cnt in enumerate(self.counts):
            if cnt > 0:
                yield a, int(cnt)


def _build_images(room, src, mics, *, max_order, radius_m, sign, drop_silent=True, reflection=None):
    """Enumerate the image set: L1 ball of ``max_order`` and/or the sphere of ``radius_m``.

    ``reflection`` (n_bands, 6) per-band wall pressure reflections (default the room's, one
    band).  With ``drop_silent`` images whose gain is exactly 0 in every band are skipped.
    """
    dims = np.asarray(room.dims_m)
    b = np.atleast_2d(room.reflection if reflection is None else reflection)
    if max_order is not None:
        nmax = np.full(3, max_order)
        if radius_m is not None:  # both: the L1 ball cut to the sphere's bounding box
            nmax = np.minimum(nmax, np.ceil(radius_m / dims).astype(int) + 1)
    else:
        # |i| L - L <= |x_img - x_mic| for any mic inside the room, so this bounds the sphere.
        nmax = np.ceil(radius_m / dims).astype(int) + 1
    axes = [
        _axis_terms(dims[d], src[d], mics[:, d], int(nmax[d]), b[:, 2 * d], b[:, 2 * d + 1], sign)
        for d in range(3)
    ]
    (ix, offx, gx), (iy, offy, gy), (iz, offz, gz) = axes
    dx2, dy2, dz2 = offx**2, offy**2, offz**2
    jj, kk = np.meshgrid(np.arange(iy.size), np.arange(iz.size), indexing="ij")
    jj, kk = jj.ravel(), kk.ravel()
    order_jk = np.abs(iy[jj]) + np.abs(iz[kk])
    keep = np.ones(jj.size, bool)
    if drop_silent:
        keep &= np.any(gy[:, jj] * gz[:, kk] != 0, axis=0)
    if max_order is not None:
        keep &= order_jk <= max_order
    jj, kk, order_jk = jj[keep], kk[keep], order_jk[keep]
    dyz2 = dy2[:, jj] + dz2[:, kk]
    r2_limit = None if radius_m is None else radius_m**2
    min_dx2 = dx2.min(axis=0)
    if max_order is not None:
        perm = np.argsort(order_jk, kind="stable")
        key = order_jk[perm]
        counts = np.searchsorted(key, max_order - np.abs(ix), side="right")
    else:
        key_all = dyz2.min(axis=0)
        perm = np.argsort(key_all, kind="stable")
        key = key_all[perm]
        counts = np.where(
            r2_limit - min_dx2 >= 0, np.searchsorted(key, r2_limit - min_dx2, side="right"), 0
        )
    dyz2 = dyz2[:, perm]
    if drop_silent:
        counts = np.where(np.any(gx != 0, axis=0), counts, 0)
    # Largest squared distance: per slice, the running max of the sorted prefix.
    r2_max = 0.0
    if perm.size:
        cummax = np.maximum.accumulate(dyz2, axis=1)
        nz = counts > 0
        if np.any(nz):
            r2_max = float(np.max(dx2[:, nz] + cummax[:, counts[nz] - 1]))
    if r2_limit is not None:
        r2_max = min(r2_max, r2_limit)
    return _Images(
        ix, np.ascontiguousarray(offx), np.ascontiguousarray(gx), iy, np.ascontiguousarray(offy),
        np.ascontiguousarray(gy), iz, np.ascontiguousarray(offz), np.ascontiguousarray(gz),
        np.ascontiguousarray(jj[perm]), np.ascontiguousarray(kk[perm]), counts.astype(np.int64),
        r2_max,
    )


def image_sources(room: ShoeBox, source_m, *, max_order: int, reflection_sign: float = 1.0):
    """All images of the L1 ball ``|i| + |j| + |k| <= max_order`` (including silent ones).

    Returns
    -------
    indices : (n_images, 3) int array of (i, j, k)
    positions_m : (n_images, 3) float array of image positions
    gains : (n_images,) float array of reflection gains ``prod b^hits * sign^order``
    """
    src = room.check_inside(source_m, name="source_m")
    max_order = check_int("max_order", max_order, minimum=0)
    imgs = _build_images(
        room, src, src[None, :], max_order=max_order, radius_m=None, sign=reflection_sign,
        drop_silent=False,
    )
    dims = np.asarray(room.dims_m)
    out_idx, out_g = [], []
    for a, cnt in imgs.slices():
        i = np.full(cnt, imgs.ix[a])
        j, k = imgs.pj[:cnt], imgs.pk[:cnt]
        out_idx.append(np.column_stack([i, imgs.iy[j], imgs.iz[k]]))
        out_g.append(imgs.gx[0, a] * imgs.gy[0, j] * imgs.gz[0, k])
    idx = np.concatenate(out_idx)
    pos = idx * dims + np.where(idx % 2 == 0, src, dims - src)
    return idx, pos, np.concatenate(out_g)


def image_count_l1(max_order: int) -> int:
    """Number of lattice points with ``|i| + |j| + |k| <= N``: ``1 + 2N(2N^2 + 3N + 4)/3``."""
    n = check_int("max_order", max_order, minimum=0)
    return 1 + 2 * n * (2 * n * n + 3 * n + 4) // 3


# --------------------------------------------------------------------------- kernels
def windowed_sinc(t: np.ndarray, half_width: float = SINC_HALF_WIDTH) -> np.ndarray:
    """Hann-windowed sinc ``0.5 (1 + cos(pi t / T)) sinc(t)`` for ``|t| < T``, else 0."""
    t = np.asarray(t, dtype=float)
    w = np.where(np.abs(t) < half_width, 0.5 * (1.0 + np.cos(np.pi * t / half_width)), 0.0)
    return w * np.sinc(t)


def _chunks(imgs: _Images, limit: int):
    """Yield ``(a, j positions, k positions)``: every slice cut into pieces of <= ``limit`` images."""
    for a, cnt in imgs.slices():
        for lo in range(0, cnt, limit):
            hi = min(cnt, lo + limit)
            yield a, imgs.pj[lo:hi], imgs.pk[lo:hi]


def _chunk_terms(imgs: _Images, a, j, k, fs, c, pattern):
    """Delays (n_mics, n) in samples and per-band amplitudes (n_bands, n_mics, n) of one chunk."""
    ox = imgs.offx[:, a : a + 1]
    oy, oz = imgs.offy[:, j], imgs.offz[:, k]
    r = np.sqrt(ox**2 + oy**2 + oz**2)
    g = imgs.gx[:, a : a + 1] * imgs.gy[:, j] * imgs.gz[:, k]  # (n_bands, n)
    amp = g[:, None, :] / (4.0 * np.pi * r)[None]
    if pattern is not None:
        axis, coef = pattern
        cos_t = (ox * axis[0] + oy * axis[1] + oz * axis[2]) / r
        d = np.zeros((coef.shape[0],) + r.shape)
        for col in range(coef.shape[1] - 1, -1, -1):  # Horner in cos(theta), per band
            d = d * cos_t[None] + coef[:, col, None, None]
        amp = amp * d
    return r * (fs / c), amp


def _render_exact(imgs: _Images, n_taps: int, fs, c, pattern=None) -> np.ndarray:
    """Windowed-sinc sum, (n_bands, n_mics, n_taps); memory bounded by :data:`_EXACT_CHUNK`."""
    n_mics, n_bands = imgs.n_mics, imgs.gx.shape[0]
    half = SINC_HALF_WIDTH
    offs = np.arange(-half + 1, half + 1)  # floor(D) + offs covers every |n - D| < T
    out = np.zeros((n_bands, n_mics * n_taps))
    mic_base = (np.arange(n_mics) * n_taps)[:, None, None]
    for a, j, k in _chunks(imgs, _EXACT_CHUNK):
        dly, amp = _chunk_terms(imgs, a, j, k, fs, c, pattern)
        n = np.floor(dly).astype(np.int64)[:, :, None] + offs  # (m, n, taps)
        ker = windowed_sinc(n - dly[:, :, None], half)
        ok = (n >= 0) & (n < n_taps)  # kernels reach before t = 0 and past the last tap
        flat = (n + mic_base)[ok]
        for band in range(n_bands):
            vals = amp[band][:, :, None] * ker
            out[band] += np.bincount(flat, vals[ok], minlength=out.shape[1])
    return out.reshape(n_bands, n_mics, n_taps)


@functools.lru_cache(maxsize=32)
def _polyphase_kernel_fft(u: int, n_fft: int, double: bool = False) -> np.ndarray:
    """FFTs ``(u, n_fft // 2 + 1)`` of the windowed-sinc kernel's polyphase branches.

    With ``X_j[k] = grid[k u + j]`` the decimated filter output
    ``y[n] = sum_m h[m] grid[n u - m]`` is ``conv(h[0::u], X_0) + z^-1 sum_{b>0} conv(h[b::u], X_{u-b})``;
    branch ``j`` therefore holds ``h[0::u]`` (j = 0) or ``h[(u-j)::u]`` delayed by one (j > 0).
    """
    half = SINC_HALF_WIDTH
    h = windowed_sinc(np.arange(-half * u, half * u + 1) / u, half)
    n_a = 2 * half + 2
    hp = np.zeros((u, n_a))
    padded = np.zeros(n_a * u)
    padded[: h.size] = h
    poly = padded.reshape(n_a, u).T  # poly[b, a] = h[a u + b]
    hp[0] = poly[0]
    for j in range(1, u):
        hp[j, 1:] = poly[u - j, :-1]
    spec = sfft.rfft(hp, n_fft, axis=-1)
    spec = spec if double else spec.astype(np.complex64)
    spec.flags.writeable = False  # cached and shared between calls
    return spec


_WORKSPACE = threading.local()
_WORKSPACE_MAX_BYTES = 16 << 20


def _workspace(name: str, shape: tuple, dtype) -> np.ndarray:
    """A zeroed array, reused between calls of this thread when it is small.

    Why: at short RT60 the fast renderer's fresh buffers cost more in first-touch page faults
    (~1.5 ms for ~3 MB under load) than the scatter itself; zeroing a resident buffer is a
    memset.  Large buffers are not kept (memory stays bounded by the call).
    """
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    if nbytes > _WORKSPACE_MAX_BYTES:
        return np.zeros(shape, dtype)
    cache = getattr(_WORKSPACE, "arrays", None)
    if cache is None:
        cache = _WORKSPACE.arrays = {}
    size = int(np.prod(shape))
    flat = cache.get(name)
    if flat is None or flat.dtype != dtype or flat.size < size:
        flat = cache[name] = np.zeros(size, dtype)
    arr = flat[:size]
    arr.fill(0)
    return arr.reshape(shape)


def _render_fast(imgs: _Images, n_taps: int, fs, c, pattern=None, oversampling: int = FAST_OVERSAMPLING):
    """Scatter on a U-times oversampled grid (compiled), then polyphase FFT filter and decimate.

    Returns (n_bands, n_mics, n_taps).  Memory: the grid, n_bands x n_mics x ~U n_taps floats.
    """
    from scenesim.room.ism_kernels import scatter_images, scatter_omni  # lazy: numba import ~0.3 s

    n_mics, n_bands = imgs.n_mics, imgs.gx.shape[0]
    u = int(oversampling)
    half = SINC_HALF_WIDTH
    g0 = (half + 1) * u  # fine index of t = 0; leaves room for the cubic left neighbour
    n_blocks = half + 1 + n_taps + half + 1
    n_fine = n_blocks * u
    q_max = g0 + float(n_taps - 1 + half) * u  # images later than this cannot reach the last tap
    scale = fs * u / c  # metres -> fine-grid samples
    # float64 grid: exact accumulation order does not matter then (reciprocity holds to 1e-12);
    # the FFT stage below runs in float32.
    grid = _workspace("grid", (n_bands, n_mics, n_fine), np.float64)
    if pattern is None and n_bands == 1:
        dyz2 = imgs.offy[:, imgs.pj] ** 2 + imgs.offz[:, imgs.pk] ** 2
        gyz = imgs.gy[0, imgs.pj] * imgs.gz[0, imgs.pk]
        scatter_omni(imgs.offx**2, imgs.gx[0], dyz2, gyz, imgs.counts, grid[0], scale, float(g0), q_max)
    else:
        axis, coef = (np.zeros(3), np.zeros((n_bands, 0))) if pattern is None else pattern
        scatter_images(
            imgs.offx, imgs.gx, imgs.offy, imgs.gy, imgs.offz, imgs.gz, imgs.pj, imgs.pk,
            imgs.counts, np.ascontiguousarray(axis, dtype=float),
            np.ascontiguousarray(coef, dtype=float), grid, scale, float(g0), q_max,
        )
    out = np.empty((n_bands, n_mics, n_taps))
    for band in range(n_bands):  # one band at a time keeps the FFT buffers small
        out[band] = decimate_grid(grid[band], n_taps, u)
    return out


def decimate_grid(grid: np.ndarray, n_taps: int, u: int, *, dtype=np.float32) -> np.ndarray:
    """Filter a scatter grid ``(n_mics, n_fine)`` by the windowed sinc at the fine rate and decimate by ``u``.

    ``n_fine = (2 (SINC_HALF_WIDTH + 1) + n_taps) u``; fine index ``(SINC_HALF_WIDTH + 1) u``
    is t = 0.  Returns ``(n_mics, n_taps)``.  ``dtype`` of the FFT stage: float32 (error ~1e-7
    of the peak, below the fast renderer's interpolation error) or float64.
    """
    half = SINC_HALF_WIDTH
    n_mics = grid.shape[0]
    n_blocks = grid.shape[1] // u
    n_fft = sfft.next_fast_len(n_blocks + 2 * half + 2, real=True)
    kernel = _polyphase_kernel_fft(u, n_fft, dtype != np.float32)
    start = 2 * half + 1  # y[n] = sum_images a h(n - (half + 1) - half - D): tap t = n - (2 half + 1)
    # x[m, j, k] = grid[k u + j], zero-padded to n_fft, C-contiguous along k (pocketfft is
    # ~20x slower on a strided axis).
    x = _workspace("x", (n_mics, u, n_fft), dtype)
    x[:, :, :n_blocks] = grid.reshape(n_mics, n_blocks, u).transpose(0, 2, 1)
    spec = sfft.rfft(x, axis=-1)
    spec *= kernel
    y = sfft.irfft(spec.sum(axis=1), n_fft, axis=-1)
    return y[:, start : start + n_taps]


# --------------------------------------------------------------------------- public
def _as_mics(room: ShoeBox, mics_m) -> np.ndarray:
    m = np.asarray(mics_m, dtype=float) if not isinstance(mics_m, str) else None
    if m is None or m.ndim not in (1, 2) or m.shape[-1] != 3 or m.size == 0:
        raise ParameterError("mics_m", mics_m, "an array shaped (3,) or (n_mics, 3) in metres")
    m = np.atleast_2d(m)
    for k, p in enumerate(m):
        room.check_inside(p, name=f"mics_m[{k}]")
    return m


def default_length_s(room: ShoeBox, source_m, mics_m, c: float | None = None) -> float:
    """Default RIR length (s): 1.2 x nominal RT60 (target or Sabine) + the longest direct path."""
    c = room.c if c is None else float(c)
    src = np.asarray(source_m, dtype=float)
    mics = np.atleast_2d(np.asarray(mics_m, dtype=float))
    direct = float(np.max(np.linalg.norm(mics - src, axis=1))) / c
    return DEFAULT_LENGTH_RT60_FACTOR * room.nominal_rt60_s + direct


def _validate_common(room, source_m, mics_m, fs, method, c, max_order, reflection_sign, highpass_hz):
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
    fs = check_fs(fs)
    check_choice("method", method, METHODS)
    src = room.check_inside(source_m, name="source_m")
    mics = _as_mics(room, mics_m)
    gap = np.linalg.norm(mics - src, axis=1)
    if np.any(gap < MIN_SOURCE_MIC_DISTANCE_M):
        # 1/(4 pi r) diverges at r = 0: refuse instead of returning inf/NaN.
        raise ParameterError(
            "source_m", tuple(src.tolist()),
            f"at least {MIN_SOURCE_MIC_DISTANCE_M * 1e3:g} mm from every mic "
            f"(mic {int(np.argmin(gap))} is {float(gap.min()) * 1e3:.3g} mm away)",
        )
    c = room.c if c is None else check_positive("c", c)
    if max_order is not None:
        max_order = check_int("max_order", max_order, minimum=0, maximum=MAX_ORDER)
    if reflection_sign not in (1, -1, 1.0, -1.0) or isinstance(reflection_sign, bool):
        raise ParameterError("reflection_sign", reflection_sign, "+1 or -1")
    if highpass_hz is not None:
        highpass_hz = check_range("highpass_hz", highpass_hz, 0.0, fs / 2, lo_open=True, hi_open=True)
    return fs, src, mics, c, max_order, float(reflection_sign), highpass_hz


def _pattern_of(directivity):
    if directivity is None:
        return None
    if not isinstance(directivity, Directivity):
        raise ParameterError("directivity", directivity, "None or a scenesim.room.directivity.Directivity")
    return directivity.axis, directivity.coefficient_array


def _bands_of(directivity, reflection_bands, bands_hz) -> tuple:
    """Band centres of the render: the directivity's and/or ``bands_hz``; (1000,) for one band."""
    if bands_hz is not None:
        bands_hz = tuple(check_bands(bands_hz).tolist())
    if reflection_bands is not None and bands_hz is None:
        raise ParameterError("bands_hz", bands_hz, "band centres in Hz with reflection_bands")
    if directivity is not None and bands_hz is not None and directivity.bands_hz != bands_hz:
        raise ParameterError("bands_hz", bands_hz, f"the directivity's bands {directivity.bands_hz}")
    if bands_hz is not None:
        return bands_hz
    return (1000.0,) if directivity is None else directivity.bands_hz


def _band_reflection(room, reflection_bands, n_bands):
    """Per-band wall pressure reflections (n_bands, 6): the room's, or the caller's per band."""
    if reflection_bands is None:
        return np.broadcast_to(room.reflection, (n_bands, 6)).copy()
    r = np.asarray(reflection_bands, dtype=float)
    if r.shape != (n_bands, 6) or not np.all(np.isfinite(r)) or np.any(np.abs(r) > 1):
        raise ParameterError("reflection_bands", reflection_bands, f"an array ({n_bands}, 6) in [-1, 1]")
    return r


def image_source_rir_bands(
    room: ShoeBox,
    source_m,
    mics_m,
    *,
    fs: int,
    n_bands: int = 1,
    reflection_bands=None,
    directivity: Directivity | None = None,
    max_order: int | None = None,
    length_s: float | None = None,
    radius_m: float | None = None,
    reflection_sign: float = 1.0,
    c: float | None = None,
    method: str = "auto",
    seed: int | np.random.Generator | None = None,
) -> np.ndarray:
    """Per-band image-source RIRs ``(n_bands, n_mics, n_taps)``, before the band merge.

    The hook for frequency-dependent gains: band ``b`` uses the wall pressure reflections
    ``reflection_bands[b]`` (default: the room's, every band) and the directivity's row ``b``
    (then ``n_bands`` must equal ``directivity.n_bands``).  Merge with
    :func:`scenesim.room.ism_bands.merge_bands`.  ``radius_m`` additionally keeps only images
    within that distance of a mic (with ``max_order``, the L1 images within the sphere's
    bounding box).  Other parameters as :func:`image_source_rir` (``method`` in {"auto",
    "exact", "fast"}).

    A room with ``scattering`` is rendered as by :func:`image_source_rir`, band by band: the
    images carry the specular share ``b sqrt(1 - s)`` of every reflection and each band gets
    the scattered field of its own reflections ``reflection_bands[b]``
    (:mod:`scenesim.room.scattering`; one coherent-noise realisation for all bands, seeded by
    ``seed``, default derived from the geometry as :func:`image_source_rir`'s), whatever
    ``radius_m`` (it limits the specular images only).  So
    ``merge_bands(image_source_rir_bands(...))`` is ``image_source_rir(..., bands_hz=...)``.

    Examples
    --------
    >>> from scenesim.room.shoebox import ShoeBox
    >>> h = image_source_rir_bands(ShoeBox((4, 3, 2.5), 0.3), (1, 1, 1), (3, 2, 1.5), fs=8000,
    ...                            n_bands=2, max_order=2)
    >>> h.shape[:2]
    (2, 1)
    """
    fs, src, mics, c, max_order, sign, _ = _validate_common(
        room, source_m, mics_m, fs, method, c, max_order, reflection_sign, None
    )
    if method == "hybrid":
        raise ParameterError("method", method, "auto, exact or fast (per-band rendering)")
    n_bands = check_int("n_bands", n_bands, minimum=1)
    pattern = _pattern_of(directivity)
    if pattern is not None and directivity.n_bands != n_bands:
        raise ParameterError("n_bands", n_bands, f"{directivity.n_bands} (the directivity's bands)")
    refl = _band_reflection(room, reflection_bands, n_bands)
    scat = room.scattering_table()
    spec = refl * np.sqrt(1.0 - scat)  # specular share, as image_source_rir
    imgs, n_taps = _image_set(room, src, mics, fs, c, max_order, length_s, sign, spec, radius_m)
    h_bands = _render(imgs, n_taps, fs, c, method, pattern)
    if room.scattering is None or max_order == 0:
        return h_bands
    return _ScatteredField(room, src, mics, fs, c, refl, scat, tail_rng(room, src, mics, seed, salt=1)).add_to(h_bands)


def _image_set(room, src, mics, fs, c, max_order, length_s, sign, refl, radius_m=None):
    if length_s is None and max_order is None:
        length_s = default_length_s(room, src, mics, c)
    if length_s is not None:
        length_s = check_physical("length_s", length_s, "rir_length_s")
        n_taps = max(1, math.ceil(length_s * fs - 1e-9))
        radius = (n_taps - 1 + SINC_HALF_WIDTH) * c / fs
        if radius_m is not None:
            radius = min(radius, radius_m)
        imgs = _build_images(
            room, src, mics, max_order=max_order,
            radius_m=radius if (max_order is None or radius_m is not None) else None,
            sign=sign, reflection=refl,
        )
    else:
        imgs = _build_images(
            room, src, mics, max_order=max_order, radius_m=radius_m, sign=sign, reflection=refl
        )
        n_taps = int(math.floor(math.sqrt(imgs.r2_max) * fs / c)) + SINC_HALF_WIDTH + 1
    return imgs, n_taps


def _render(imgs, n_taps, fs, c, method, pattern):
    if method == "auto":
        method = "exact" if imgs.n_images * imgs.n_mics <= AUTO_EXACT_MAX_TERMS else "fast"
    if method == "exact":
        return _render_exact(imgs, n_taps, fs, c, pattern)
    return _render_fast(imgs, n_taps, fs, c, pattern)


def image_source_rir(
    room: ShoeBox,
    source_m,
    mics_m,
    *,
    fs: int,
    max_order: int | None = None,
    length_s: float | None = None,
    highpass_hz: float | None = None,
    reflection_sign: float = 1.0,
    c: float | None = None,
    method: str = "auto",
    directivity: Directivity | None = None,
    reflection_bands=None,
    bands_hz=None,
    mixing_time_s: float | None = None,
    seed: int | np.random.Generator | None = None,
) -> np.ndarray:
    """Room impulse responses from one source to every mic by the image-source method.

    Parameters
    ----------
    room : ShoeBox
    source_m : (3,) array
        Source position in metres (inside the room, ``room.min_wall_distance_m`` from walls,
        and at least :data:`MIN_SOURCE_MIC_DISTANCE_M` from every mic).
    mics_m : (3,) or (n_mics, 3) array
        Mic positions in metres.
    fs : int
        Sampling rate in Hz.
    max_order : int, optional
        Keep images with ``|i| + |j| + |k| <= max_order`` (pyroomacoustics' L1 bound).
        None: every image arriving within the RIR length (plus the kernel's half width).
        It bounds the *specular* images only: a room with ``scattering`` adds its scattered
        field, a diffuse tail drawn from the room's decay rather than from images, whatever the
        order (so ``max_order=1`` in a scattering room keeps the full T30). For an order-limited
        RIR set the room's scattering to 0 (``ShoeBox(..., scattering=0)``, ``rir --scattering 0``);
        ``length_s`` bounds both parts. At most :data:`MAX_ORDER`.
    length_s : float, optional
        RIR length in seconds, ``n_taps = ceil(length_s fs)``; images arriving later are
        pruned.  Default: with ``max_order``, long enough for the last image's full kernel
        (``floor(D_max) + 41`` taps); without, 1.2 x the nominal RT60 (``rt60_s`` if the room
        was given one, else Sabine) plus the longest direct-path time.
    highpass_hz : float, optional
        Cut-off of a causal 2nd-order Butterworth high-pass applied to the RIR (in the spirit
        of Allen & Berkley's 100 Hz filter); off by default.
    reflection_sign : {+1, -1}
        Sign per reflection (-1 as gpuRIR/Lehmann): the image gain gets ``sign^order``.
    c : float, optional
        Speed of sound in m/s; default ``room.c``.
    method : {"auto", "exact", "fast", "hybrid"}
        Renderer (module docstring).  "hybrid": images up to ``mixing_time_s`` (the first
        ``mixing_time_s fs`` taps equal the full ISM's), then a seeded stochastic tail with
        the ISM's expected per-band decay and diffuse-field coherence between the mics
        (:mod:`scenesim.room.hybrid`).
    directivity : Directivity, optional
        Source directivity (:mod:`scenesim.room.directivity`), evaluated per image at its emission
        direction; with several bands one RIR per band is rendered and merged
        (:mod:`scenesim.room.ism_bands`).  None: omnidirectional.
    reflection_bands : (n_bands, 6) array, optional
        Per-band wall pressure reflections ``sqrt(1 - alpha)`` in wall order (frequency-
        dependent absorption), rendered per band and merged; needs ``bands_hz``.  Default:
        the room's, every band.
    bands_hz : (n_bands,) array, optional
        Band centres of ``reflection_bands`` (must equal ``directivity.bands_hz`` when both
        are given).
    mixing_time_s : float, optional
        Hybrid only: end of the image-source part, default :data:`DEFAULT_MIXING_TIME_S`.
    seed : int or numpy.random.Generator, optional
        Seed of the stochastic parts: the hybrid's tail and a scattering room's scattered field
        (any method).  Default: derived from the room, source and mic positions (reproducible,
        and different for two sources in one scene, whose tails would otherwise be the same
        noise and correlated).

    Returns
    -------
    (n_mics, n_taps) float64 array, physical scale ``g / (4 pi r)``, tap 0 = emission time.

    Examples
    --------
    >>> from scenesim.room.shoebox import ShoeBox
    >>> h = image_source_rir(ShoeBox((4, 3, 2.5), 0.3), (1, 1, 1), (3, 2, 1.5), fs=8000, max_order=3)
    >>> h.shape[0]
    1
    """
    fs, src, mics, c, max_order, sign, highpass_hz = _validate_common(
        room, source_m, mics_m, fs, method, c, max_order, reflection_sign, highpass_hz
    )
    pattern = _pattern_of(directivity)
    bands = _bands_of(directivity, reflection_bands, bands_hz)
    n_bands = len(bands)
    refl = _band_reflection(room, reflection_bands, n_bands)
    scat = room.scattering_table()
    spec = refl * np.sqrt(1.0 - scat)  # specular share of every reflection (scenesim.room.scattering)
    if method != "hybrid":
        if mixing_time_s is not None:
            raise ParameterError("mixing_time_s", mixing_time_s, "only with method='hybrid'")
        imgs, n_taps = _image_set(room, src, mics, fs, c, max_order, length_s, sign, spec)
        h_bands = _render(imgs, n_taps, fs, c, method, pattern)
    scattered = room.scattering is not None and max_order != 0  # order 0: the direct path only
    field = (_ScatteredField(room, src, mics, fs, c, refl, scat, tail_rng(room, src, mics, seed, salt=1))
             if scattered else None)
    if method == "hybrid":
        h_bands = _hybrid(
            room, src, mics, fs, c, max_order, length_s, sign, spec, pattern, mixing_time_s, seed, field
        )
    if scattered:
        h_bands = field.add_to(h_bands)
    h = h_bands[0] if n_bands == 1 else merge_bands(h_bands, fs, bands)
    if highpass_hz is not None:
        h = highpass(h, highpass_hz, fs)
    return h


@functools.lru_cache(maxsize=16)
def _highpass_sos(highpass_hz: float, fs: int) -> np.ndarray:
    return signal.butter(2, highpass_hz, btype="highpass", fs=fs, output="sos")


def highpass(h: np.ndarray, highpass_hz: float, fs: int) -> np.ndarray:
    """``h`` (..., n_taps) through the causal 2nd-order Butterworth high-pass of :func:`image_source_rir`.

    The design is cached (it cost as much as filtering a 1 s RIR pair).

    >>> float(highpass(np.ones(16000), 20.0, 16000)[-1]) < 1e-3
    True
    """
    # a copy: sosfilt wants a writable array, and the cached one must not change
    return signal.sosfilt(_highpass_sos(float(highpass_hz), int(fs)).copy(), h, axis=-1)


def tail_rng(room, src, mics, seed, salt: int = 0) -> np.random.Generator:
    """The generator of a stochastic tail: ``seed``, or derived from the geometry when None
    (positions in micrometres as the entropy; ``salt`` tells two tails of one RIR apart).

    With one receiver the two end points enter in sorted order, so swapping source and receiver draws
    the same tail and the whole RIR is reciprocal, as a room's is (the specular part is by
    construction). With several mics the tail is drawn jointly for all of them (its inter-mic
    coherence) and only the full geometry seeds it.
    """
    if seed is None:
        ends = sorted([tuple(np.asarray(src, float).tolist()), tuple(mics[0].tolist())]) if len(mics) == 1 else None
        points = np.concatenate([*ends]) if ends else np.concatenate([src, mics.ravel()])
        words = np.round(np.concatenate([room.dims_m, points]) * 1e6).astype(np.int64)
        seed = np.random.SeedSequence([int(w) % 2**63 for w in words] + ([salt] if salt else []))
    elif salt and not isinstance(seed, np.random.Generator):
        seed = np.random.SeedSequence([int(seed), salt]) if isinstance(seed, int) else seed
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


class _ScatteredField:
    """The room's scattered field (:mod:`scenesim.room.scattering`) for one source and mics, per
    length: its coherent noise (drawn once) and expected energy (computed once).  The hybrid's
    specular tail reuses the noise circularly shifted by half its length (white noise:
    independent samples, the same inter-mic coherence), which saves one draw and keeps the
    scattered part -- and so the early taps -- identical to the full model's; it reads the
    energy to skip octave shaping that the scattered field would drown."""

    def __init__(self, room, src, mics, fs, c, refl, scat, rng):
        self._args, self._rng, self._noise, self._energy = (room, src, mics, fs, c, refl, scat), rng, {}, {}

    def noise(self, n_taps: int) -> np.ndarray:
        """Coherent noise ``(n_mics, n_taps)``."""
        from scenesim.room.hybrid import coherent_noise

        if n_taps not in self._noise:
            _, _, mics, fs, c, _, _ = self._args
            self._noise[n_taps] = coherent_noise(mics, n_taps, fs=fs, c=c, rng=self._rng)
        return self._noise[n_taps]

    def _tables(self):
        room, src, mics, fs, c, refl, scat = self._args
        t0 = float(np.min(np.linalg.norm(mics - src, axis=1))) / c
        return (room.dims_m, refl, np.broadcast_to(scat, refl.shape)), {"fs": fs, "c": c, "t0_s": t0}

    def energy(self, n_taps: int) -> np.ndarray:
        """Expected ``h^2`` per tap ``(n_bands, n_taps)``."""
        from scenesim.room.scattering import scattered_energy

        if n_taps not in self._energy:
            args, kw = self._tables()
            self._energy[n_taps] = scattered_energy(*args, n_taps, **kw)
        return self._energy[n_taps]

    def add_to(self, h_bands: np.ndarray) -> np.ndarray:
        """``h_bands`` (n_bands, n_mics, n_taps) plus the scattered field
        (:func:`scenesim.room.scattering.scattered_tail`)."""
        from scenesim.room.scattering import scattered_tail

        n_taps = h_bands.shape[-1]
        (dims, refl, scat), kw = self._tables()
        return h_bands + scattered_tail(dims, refl, scat, self._args[2], n_taps=n_taps, rng=None,
                                        noise=self.noise(n_taps), energy=self.energy(n_taps), **kw)


def _hybrid(room, src, mics, fs, c, max_order, length_s, sign, refl, pattern, mixing_time_s, seed,
            scattered=None):
    """Early images (full-ISM identical up to the mixing time) + a coherent stochastic tail."""
    from scenesim.room.hybrid import crossfade, diffuse_tail

    t_mix = DEFAULT_MIXING_TIME_S if mixing_time_s is None else check_positive("mixing_time_s", mixing_time_s)
    if length_s is None:
        if max_order is None:
            length_s = default_length_s(room, src, mics, c)
        else:  # the full ISM's default length with this order
            length_s = (_image_set(room, src, mics, fs, c, max_order, None, sign, refl[:1])[1]) / fs
    n_taps = max(1, math.ceil(check_physical("length_s", length_s, "rir_length_s") * fs - 1e-9))
    n_mix = min(n_taps, max(1, round(t_mix * fs)))
    # Images reaching any tap < n_mix: the early taps equal the full ISM's.
    radius = (n_mix - 1 + SINC_HALF_WIDTH) * c / fs
    n_early = min(n_taps, n_mix + SINC_HALF_WIDTH)
    imgs, _ = _image_set(room, src, mics, fs, c, max_order, n_early / fs, sign, refl, radius_m=radius)
    early = _render(imgs, n_early, fs, c, "fast", pattern)
    if n_mix >= n_taps:
        return early[..., :n_taps]
    rng = tail_rng(room, src, mics, seed)
    # Level of the tail matched over [max(t_mix / 2, direct + 10 ms), t_mix): late enough to
    # hold no direct sound, long enough (>= 5 ms) to average many images; else analytic level.
    direct = float(np.max(np.linalg.norm(mics - src, axis=1))) / c
    lo = max(n_mix // 2, math.ceil((direct + 0.01) * fs))
    window = (lo, n_mix) if n_mix - lo >= 0.005 * fs else None
    shared = None if scattered is None else np.roll(scattered.noise(n_taps), n_taps // 2, axis=-1)
    tail = diffuse_tail(
        room, mics, n_taps=n_taps, fs=fs, c=c, reflection=refl, pattern=pattern,
        max_order=max_order, rng=rng, early=early, window=window, noise=shared,
        floor=None if scattered is None else scattered.energy(n_taps),
    )
    return crossfade(early, tail, n_mix, SINC_HALF_WIDTH)


__all__ = [
    "AUTO_EXACT_MAX_TERMS",
    "DEFAULT_LENGTH_RT60_FACTOR",
    "FAST_OVERSAMPLING",
    "SINC_HALF_WIDTH",
    "DEFAULT_MIXING_TIME_S",
    "MIN_SOURCE_MIC_DISTANCE_M",
    "decimate_grid",
    "default_length_s",
    "highpass",
    "image_count_l1",
    "image_source_rir",
    "image_source_rir_bands",
    "image_sources",
    "windowed_sinc",
]
