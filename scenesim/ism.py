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

Two renderers:

* ``"exact"``: the windowed-sinc sum above, vectorised over images and taps; equals the
  scalar triple-loop reference in ``tests/ism_reference.py`` to 1e-10.
* ``"fast"``: each image's amplitude is scattered onto a time grid oversampled by
  :data:`FAST_OVERSAMPLING` with 4-point (cubic) Lagrange weights (``np.bincount``), then the
  grid is filtered by the same windowed sinc sampled at the fine rate and decimated by U
  (polyphase: U branch convolutions done as float32 FFTs, which beat
  ``scipy.signal.upfirdn``'s direct polyphase loop by ~5x at these lengths).  This equals
  the exact sum with the kernel cubic-interpolated between fine-grid points: interpolation
  error <= ~0.46 / U^4 of the peak (U = 16: ~7e-6); measured against ``"exact"``: relative
  L2 error 4e-6..7e-6, max error 7e-6 of the peak (``tests/test_ism.py`` asserts 3e-5).
  Cost per image is O(1), independent of the kernel length; images arriving after the
  last tap are pruned.

``method="auto"`` uses ``"exact"`` for small image sets (<= :data:`AUTO_EXACT_MAX_TERMS`
image-mic terms) and ``"fast"`` otherwise.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy import signal

from scenesim.errors import ParameterError
from scenesim.room import ShoeBox
from scenesim.validate import check_choice, check_fs, check_int, check_positive, check_range

SINC_HALF_WIDTH = 40
"""Half width T (samples) of the Hann-windowed sinc: support |t| < T (81-tap footprint)."""
FAST_OVERSAMPLING = 16
"""Oversampling factor U of the fast renderer's scatter grid."""
AUTO_EXACT_MAX_TERMS = 20_000
"""``method="auto"`` renders exactly when images x mics is at most this."""
DEFAULT_LENGTH_RT60_FACTOR = 1.2
"""Default RIR length: this factor x the room's nominal RT60 plus the longest direct path."""
_CHUNK = 1 << 20  # image-mic terms per scatter batch (bounded memory: ~10 arrays of 8 MiB)
_EXACT_CHUNK = 1 << 14  # images per exact batch (x 80 taps x n_mics terms)
METHODS = ("auto", "exact", "fast")


# --------------------------------------------------------------------------- enumeration
def _axis_terms(length, s, mic, n_max, b0, b_l, sign):
    """Per-axis image terms: indices (n,), squared offsets (n_mics, n), gains (n,)."""
    i = np.arange(-n_max, n_max + 1)
    pos = i * length + np.where(i % 2 == 0, s, length - s)
    d2 = (pos[None, :] - mic[:, None]) ** 2
    n = np.abs(i)
    n0 = np.where(i > 0, n // 2, (n + 1) // 2)
    gain = b0 ** n0 * b_l ** (n - n0) * sign ** n
    return i, d2, gain


@dataclass
class _Images:
    """Separable description of an image set, enumerated as per-``i`` prefixes of sorted (j, k) pairs."""

    ix: np.ndarray  # (nx,) x indices
    dx2: np.ndarray  # (n_mics, nx)
    gx: np.ndarray  # (nx,)
    jk: np.ndarray  # (P, 2) sorted (j, k) pairs
    dyz2: np.ndarray  # (n_mics, P)
    gyz: np.ndarray  # (P,)
    counts: np.ndarray  # (nx,) prefix length per x index
    r2_max: float  # largest squared distance in the set (over mics)

    @property
    def n_images(self) -> int:
        return int(self.counts.sum())

    def slices(self):
        """Yield ``(x position index, prefix count)`` for every non-empty slice."""
        for a, cnt in enumerate(self.counts):
            if cnt > 0:
                yield a, int(cnt)


def _build_images(room, src, mics, *, max_order, radius_m, sign, drop_silent=True):
    """Enumerate the image set: L1 ball of ``max_order`` and/or the sphere of ``radius_m``.

    With ``drop_silent`` images whose gain is exactly 0 (a wall with alpha = 1) are skipped.
    """
    dims = np.asarray(room.dims_m)
    b = room.reflection
    if max_order is not None:
        nmax = np.full(3, max_order)
    else:
        # |i| L - L <= |x_img - x_mic| for any mic inside the room, so this bounds the sphere.
        nmax = np.ceil(radius_m / dims).astype(int) + 1
    axes = [
        _axis_terms(dims[d], src[d], mics[:, d], int(nmax[d]), b[2 * d], b[2 * d + 1], sign)
        for d in range(3)
    ]
    (ix, dx2, gx), (iy, dy2, gy), (iz, dz2, gz) = axes
    jj, kk = np.meshgrid(np.arange(iy.size), np.arange(iz.size), indexing="ij")
    jj, kk = jj.ravel(), kk.ravel()
    gyz = gy[jj] * gz[kk]
    dyz2 = dy2[:, jj] + dz2[:, kk]
    order_jk = np.abs(iy[jj]) + np.abs(iz[kk])
    keep = np.ones(jj.size, bool)
    if drop_silent:
        keep &= gyz != 0
    if max_order is not None:
        keep &= order_jk <= max_order
    jj, kk, gyz, dyz2, order_jk = jj[keep], kk[keep], gyz[keep], dyz2[:, keep], order_jk[keep]
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
    jk = np.stack([iy[jj[perm]], iz[kk[perm]]], axis=1)
    dyz2 = np.ascontiguousarray(dyz2[:, perm])
    gyz = gyz[perm]
    if drop_silent:
        counts = np.where(gx != 0, counts, 0)
    # Largest squared distance: per slice, the running max of the sorted prefix.
    r2_max = 0.0
    if jk.shape[0]:
        cummax = np.maximum.accumulate(dyz2, axis=1)
        nz = counts > 0
        if np.any(nz):
            r2_max = float(np.max(dx2[:, nz] + cummax[:, counts[nz] - 1]))
    if r2_limit is not None:
        r2_max = min(r2_max, r2_limit)
    return _Images(ix, dx2, gx, jk, dyz2, gyz, counts, r2_max)


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
        out_idx.append(np.column_stack([i, imgs.jk[:cnt]]))
        out_g.append(imgs.gx[a] * imgs.gyz[:cnt])
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


def _slice_terms(imgs: _Images, a: int, cnt: int, fs: float, c: float):
    """Delays (n_mics, cnt) in samples and amplitudes (n_mics, cnt) of one x slice."""
    r = np.sqrt(imgs.dx2[:, a : a + 1] + imgs.dyz2[:, :cnt])
    g = imgs.gx[a] * imgs.gyz[:cnt]
    amp = g / (4.0 * np.pi * r)
    return r * (fs / c), amp


def _batches(imgs: _Images, fs, c, limit):
    """Yield (mic row (m,), delay (m,), amplitude (m,)) batches of about ``limit`` terms."""
    n_mics = imgs.dx2.shape[0]
    buf_d, buf_a, size = [], [], 0
    for a, cnt in imgs.slices():
        d, amp = _slice_terms(imgs, a, cnt, fs, c)
        buf_d.append(d)
        buf_a.append(amp)
        size += d.size
        if size >= limit:
            yield np.concatenate(buf_d, axis=1), np.concatenate(buf_a, axis=1)
            buf_d, buf_a, size = [], [], 0
    if buf_d:
        yield np.concatenate(buf_d, axis=1), np.concatenate(buf_a, axis=1)
    elif n_mics == 0:  # pragma: no cover - validated earlier
        return


def _render_exact(imgs: _Images, n_taps: int, fs, c) -> np.ndarray:
    n_mics = imgs.dx2.shape[0]
    half = SINC_HALF_WIDTH
    offs = np.arange(-half + 1, half + 1)  # floor(D) + offs covers every |n - D| < T
    out = np.zeros(n_mics * n_taps)
    mic_base = (np.arange(n_mics) * n_taps)[:, None, None]
    for dly, amp in _batches(imgs, fs, c, _EXACT_CHUNK):
        base = np.floor(dly).astype(np.int64)
        n = base[:, :, None] + offs  # (m, k, taps)
        vals = amp[:, :, None] * windowed_sinc(n - dly[:, :, None], half)
        ok = n < n_taps  # n >= 0 always? no: n can be negative near t = 0
        ok &= n >= 0
        out += np.bincount((n + mic_base)[ok], vals[ok], minlength=out.size)
    return out.reshape(n_mics, n_taps)


@functools.lru_cache(maxsize=32)
def _polyphase_kernel_fft(u: int, n_fft: int) -> np.ndarray:
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
    spec = sfft.rfft(hp, n_fft, axis=-1).astype(np.complex64)
    spec.flags.writeable = False  # cached and shared between calls
    return spec


class _Scatter:
    """Preallocated buffers for the fast renderer: fill image terms, flush them onto the grid."""

    def __init__(self, n_mics: int, capacity: int, n_fine: int, u: int, g0: int, d_max, fs, c):
        self.n_mics, self.cap, self.n_fine = n_mics, capacity, n_fine
        self.r = np.empty((n_mics, capacity))  # squared distance, then delay on the fine grid
        self.g = np.empty(capacity)  # reflection gains
        self.amp = np.empty((n_mics, capacity))
        self.floor = np.empty((n_mics, capacity))
        self.idx = np.empty((4, n_mics, capacity), dtype=np.int64)
        self.w = np.empty((4, n_mics, capacity))
        self.tmp = np.empty((n_mics, capacity))
        self.base = (np.arange(n_mics) * n_fine)[:, None]
        self.grid = np.zeros(n_mics * n_fine)
        self.fill = 0
        self.scale = fs * u / c  # metres -> fine-grid samples
        self.g0, self.q_max = float(g0), g0 + float(d_max) * u

    def add(self, dx2_col: np.ndarray, dyz2: np.ndarray, gx: float, gyz: np.ndarray):
        cnt, done = gyz.size, 0
        while done < cnt:
            take = min(cnt - done, self.cap - self.fill)
            sl = slice(self.fill, self.fill + take)
            np.add(dx2_col, dyz2[:, done : done + take], out=self.r[:, sl])
            np.multiply(gyz[done : done + take], gx, out=self.g[sl])
            self.fill += take
            done += take
            if self.fill == self.cap:
                self.flush()

    def flush(self):
        k = self.fill
        if k == 0:
            return
        r, amp, fl, tmp = self.r[:, :k], self.amp[:, :k], self.floor[:, :k], self.tmp[:, :k]
        np.sqrt(r, out=r)
        np.divide(self.g[:k], r, out=amp)
        amp *= 1.0 / (4.0 * np.pi)
        q = r
        q *= self.scale
        q += self.g0
        late = q > self.q_max
        if np.any(late):  # prune: images this late cannot reach the requested taps
            amp[late] = 0.0
            q[late] = self.q_max
        np.floor(q, out=fl)
        f = q
        f -= fl  # fractional position in [0, 1)
        idx = self.idx[:, :, :k]
        np.add(fl, self.base, out=idx[1], casting="unsafe")
        np.subtract(idx[1], 1, out=idx[0])
        np.add(idx[1], 1, out=idx[2])
        np.add(idx[1], 2, out=idx[3])
        # 4-point Lagrange weights at nodes -1, 0, 1, 2, times the amplitude.
        w = self.w[:, :, :k]
        np.subtract(f, 1.0, out=tmp)  # f - 1
        np.multiply(f, tmp, out=w[3])  # f (f - 1)
        np.subtract(f, 2.0, out=w[0])
        np.multiply(w[0], tmp, out=w[1])  # (f - 1)(f - 2)
        np.multiply(w[1], f, out=w[0])  # f (f - 1)(f - 2)
        np.add(f, 1.0, out=tmp)  # f + 1
        w[0] *= -1.0 / 6.0
        w[1] *= tmp
        w[1] *= 0.5  # (f + 1)(f - 1)(f - 2) / 2
        np.multiply(w[3], tmp, out=w[3])  # (f + 1) f (f - 1)
        np.subtract(f, 2.0, out=w[2])
        w[2] *= f
        w[2] *= tmp
        w[2] *= -0.5  # -(f + 1) f (f - 2) / 2
        w[3] *= 1.0 / 6.0
        w *= amp
        self.grid += np.bincount(idx.ravel(), w.ravel(), minlength=self.grid.size)
        self.fill = 0


def _render_fast(imgs: _Images, n_taps: int, fs, c, oversampling: int = FAST_OVERSAMPLING):
    n_mics = imgs.dx2.shape[0]
    u = int(oversampling)
    half = SINC_HALF_WIDTH
    g0 = (half + 1) * u  # fine index of t = 0; leaves room for the cubic left neighbour
    n_blocks = half + 1 + n_taps + half + 1
    n_fine = n_blocks * u
    d_max = n_taps - 1 + half  # images later than this cannot reach the last tap
    capacity = max(1024, min(_CHUNK // n_mics, imgs.n_images))
    sc = _Scatter(n_mics, capacity, n_fine, u, g0, d_max, fs, c)
    for a, cnt in imgs.slices():
        sc.add(imgs.dx2[:, a : a + 1], imgs.dyz2[:, :cnt], imgs.gx[a], imgs.gyz[:cnt])
    sc.flush()
    x = sc.grid.reshape(n_mics, n_blocks, u).transpose(0, 2, 1)  # x[m, j, k] = grid[k u + j]
    n_fft = sfft.next_fast_len(n_blocks + 2 * half + 2, real=True)
    # float32 FFTs: their error (~1e-7 of the peak, absolute) is far below the interpolation error.
    spec = sfft.rfft(x.astype(np.float32), n_fft, axis=-1)
    spec *= _polyphase_kernel_fft(u, n_fft)
    y = sfft.irfft(spec.sum(axis=1), n_fft, axis=-1).astype(np.float64)
    del spec, x
    # y[n] = sum_images a h(n - (half + 1) - half - D): tap t = n - (2 half + 1).
    start = 2 * half + 1
    return np.ascontiguousarray(y[:, start : start + n_taps])


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
) -> np.ndarray:
    """Room impulse responses from one source to every mic by the image-source method.

    Parameters
    ----------
    room : ShoeBox
    source_m : (3,) array
        Source position in metres (inside the room, ``room.min_wall_distance_m`` from walls).
    mics_m : (3,) or (n_mics, 3) array
        Mic positions in metres.
    fs : int
        Sampling rate in Hz.
    max_order : int, optional
        Keep images with ``|i| + |j| + |k| <= max_order`` (pyroomacoustics' L1 bound).
        None: every image arriving within the RIR length (plus the kernel's half width).
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
    method : {"auto", "exact", "fast"}
        Renderer (module docstring).

    Returns
    -------
    (n_mics, n_taps) float64 array, physical scale ``g / (4 pi r)``, tap 0 = emission time.
    """
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.ShoeBox")
    fs = check_fs(fs)
    check_choice("method", method, METHODS)
    src = room.check_inside(source_m, name="source_m")
    mics = _as_mics(room, mics_m)
    c = room.c if c is None else check_positive("c", c)
    if max_order is not None:
        max_order = check_int("max_order", max_order, minimum=0)
    if reflection_sign not in (1, -1, 1.0, -1.0) or isinstance(reflection_sign, bool):
        raise ParameterError("reflection_sign", reflection_sign, "+1 or -1")
    if highpass_hz is not None:
        highpass_hz = check_range("highpass_hz", highpass_hz, 0.0, fs / 2, lo_open=True, hi_open=True)

    if length_s is None and max_order is None:
        length_s = default_length_s(room, src, mics, c)
    if length_s is not None:
        length_s = check_positive("length_s", length_s)
        n_taps = max(1, math.ceil(length_s * fs - 1e-9))
        radius = (n_taps - 1 + SINC_HALF_WIDTH) * c / fs
        imgs = _build_images(
            room, src, mics, max_order=max_order, radius_m=radius if max_order is None else None,
            sign=float(reflection_sign),
        )
    else:
        imgs = _build_images(room, src, mics, max_order=max_order, radius_m=None, sign=float(reflection_sign))
        n_taps = int(math.floor(math.sqrt(imgs.r2_max) * fs / c)) + SINC_HALF_WIDTH + 1

    if method == "auto":
        method = "exact" if imgs.n_images * mics.shape[0] <= AUTO_EXACT_MAX_TERMS else "fast"
    if method == "exact":
        h = _render_exact(imgs, n_taps, fs, c)
    else:
        h = _render_fast(imgs, n_taps, fs, c)
    if highpass_hz is not None:
        sos = signal.butter(2, highpass_hz, btype="highpass", fs=fs, output="sos")
        h = signal.sosfilt(sos, h, axis=-1)
    return h


__all__ = [
    "AUTO_EXACT_MAX_TERMS",
    "DEFAULT_LENGTH_RT60_FACTOR",
    "FAST_OVERSAMPLING",
    "SINC_HALF_WIDTH",
    "default_length_s",
    "image_count_l1",
    "image_source_rir",
    "image_sources",
    "windowed_sinc",
]
