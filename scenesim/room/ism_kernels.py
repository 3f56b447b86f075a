"""Compiled (numba) scatter kernel of the fast image-source renderer.

One pass over the image set: for every image and mic, the distance, the 1/(4 pi r) spreading,
the per-band reflection gain ``gx[b, i] gy[b, j] gz[b, k]``, the optional per-band directivity
``sum_k coef[b, k] cos^k(theta)`` and four cubic Lagrange weights scattered onto a time grid
oversampled by U.  The grid is then filtered/decimated by ``scenesim.room.ism`` (polyphase FFT).

Why compiled: the numpy version of the same scatter needed ~10 temporaries per image-mic
term and ``np.bincount``; the loop below touches each image once and allocates nothing.
``cache=True`` stores the machine code under ``__pycache__`` so only the first call in a fresh
install pays the JIT (measured by ``benchmarks/perf/ism_speed.py``).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def lagrange4(q):  # pragma: no cover - compiled
    """``(floor(q), w0..w3)``: 4-point (cubic) Lagrange weights of the nodes floor(q) - 1 .. + 2 at q."""
    fl = math.floor(q)
    f = q - fl
    fm1 = f - 1.0
    fm2 = f - 2.0
    fp1 = f + 1.0
    return int(fl), -f * fm1 * fm2 / 6.0, fp1 * fm1 * fm2 * 0.5, -fp1 * f * fm2 * 0.5, fp1 * f * fm1 / 6.0


@numba.njit(cache=True, fastmath=False, nogil=True)
def scatter_images(
    offx, gx, offy, gy, offz, gz, pj, pk, counts, axis, coef, grid, scale, g0, q_max
):  # pragma: no cover - compiled; covered through scenesim.room.ism tests (coverage cannot see it)
    """Scatter all images onto ``grid`` (n_bands, n_mics, n_fine) in place.

    grid : float64 (n_bands, n_mics, n_fine), accumulated in place
    offx : (n_mics, nx) signed mic-minus-image offsets along x, mirrored by the image parity
        (so that the emission direction in the source's frame is ``(offx, offy, offz) / r``)
    gx : (n_bands, nx) per-band reflection gains of the x factor; likewise y, z
    pj, pk : (P,) int positions into the y / z arrays of the sorted (j, k) pairs
    counts : (nx,) how many leading pairs belong to each x index
    axis : (3,) unit vector of the directivity axis (ignored when coef has no columns)
    coef : (n_bands, K) polynomial coefficients in cos(theta); K = 0 means omnidirectional
    scale : fine-grid samples per metre (fs U / c); g0 : fine index of t = 0
    q_max : fine positions beyond this are pruned (the image cannot reach a requested tap)
    """
    n_mics = offx.shape[0]
    n_bands = gx.shape[0]
    n_coef = coef.shape[1]
    inv4pi = 1.0 / (4.0 * math.pi)
    ax, ay, az = axis[0], axis[1], axis[2]
    for a in range(counts.shape[0]):
        for p in range(counts[a]):
            j = pj[p]
            k = pk[p]
            for m in range(n_mics):
                ox = offx[m, a]
                oy = offy[m, j]
                oz = offz[m, k]
                r = math.sqrt(ox * ox + oy * oy + oz * oz)
                q = r * scale + g0
                if q > q_max:
                    continue
                base, w0, w1, w2, w3 = lagrange4(q)
                spread = inv4pi / r
                cos_t = 0.0
                if n_coef > 0:
                    cos_t = (ox * ax + oy * ay + oz * az) / r
                for b in range(n_bands):
                    amp = gx[b, a] * gy[b, j] * gz[b, k] * spread
                    if n_coef > 0:
                        d = coef[b, n_coef - 1]
                        for c in range(n_coef - 2, -1, -1):
                            d = d * cos_t + coef[b, c]
                        amp *= d
                    grid[b, m, base - 1] += amp * w0
                    grid[b, m, base] += amp * w1
                    grid[b, m, base + 1] += amp * w2
                    grid[b, m, base + 2] += amp * w3


@numba.njit(cache=True, nogil=True)
def scatter_omni(dx2, gx, dyz2, gyz, counts, grid, scale, g0, q_max):  # pragma: no cover - compiled
    """Single-band, omnidirectional :func:`scatter_images` on precomputed pair terms.

    dx2 : (n_mics, nx) squared x offsets; gx : (nx,) x gains
    dyz2 : (n_mics, P) squared y + z offsets of the sorted pairs; gyz : (P,) their gains
    grid : (n_mics, n_fine); other arguments as :func:`scatter_images`.
    Reading one precomputed pair term instead of gathering y and z separately is ~25 % faster.
    """
    n_mics = dx2.shape[0]
    inv4pi = 1.0 / (4.0 * math.pi)
    for a in range(counts.shape[0]):
        ga = gx[a] * inv4pi
        for m in range(n_mics):
            dx2a = dx2[m, a]
            for p in range(counts[a]):
                r = math.sqrt(dx2a + dyz2[m, p])
                q = r * scale + g0
                if q > q_max:
                    continue
                fl = math.floor(q)
                f = q - fl
                base = int(fl)
                fm1 = f - 1.0
                fm2 = f - 2.0
                fp1 = f + 1.0
                amp = ga * gyz[p] / r
                ff = amp * f
                w = amp * fm1 * fm2
                grid[m, base - 1] += -ff * fm1 * fm2 / 6.0
                grid[m, base] += w * fp1 * 0.5
                grid[m, base + 1] += -ff * fp1 * fm2 * 0.5
                grid[m, base + 2] += ff * fp1 * fm1 / 6.0


def warm_up() -> None:
    """Compile (or load from cache) every kernel on tiny inputs."""
    z = np.zeros((1, 1))
    g = np.ones((1, 1))
    scatter_images(
        z + 1.0, g, z, g, z, g, np.zeros(1, np.int64), np.zeros(1, np.int64),
        np.ones(1, np.int64), np.array([1.0, 0.0, 0.0]), np.zeros((1, 0)),
        np.zeros((1, 1, 16)), 1.0, 4.0, 8.0,
    )
    scatter_omni(z + 1.0, np.ones(1), z, np.ones(1), np.ones(1, np.int64), np.zeros((1, 16)), 1.0, 4.0, 8.0)
    one = np.ones(1)
    scattered_steps(one * 0.5, one, one, one * 0.1, one, one * 0.9, one, np.zeros(3))  # every scattered room
    scatter_moving(one, np.zeros((1, 3)), 1.0, np.ones((1, 3)), np.ones((1, 3)), g, np.zeros((1, 3)),
                   np.zeros(1), np.zeros((1, 1, 64)), 1, 1.0, 8.0, 40.0)  # moving sources


@numba.njit(cache=True, nogil=True)
def scatter_moving(x, path, hop, base, sign, gain, mics, air_np, grid, u, scale, g0, q_max):  # pragma: no cover - compiled
    """Scatter every emitted sample of every image of a moving source onto ``grid`` in place.

    x : (n,) emitted signal; sample k leaves the image at emission time k (samples)
    path : (n_ctrl, 3) source positions every ``hop`` samples (linear between them)
    base, sign : (n_img, 3) image position = base + sign * source position (per axis)
    gain : (n_bands, n_img) reflection gains; air_np : (n_bands,) air attenuation in nepers/m
    mics : (n_mics, 3); grid : (n_bands, n_mics, n_fine) float64, accumulated
    u : oversampling U; scale : fine-grid samples per metre (fs U / c); sample k lands at
    ``k U + r scale + g0``
    q_max : fine positions beyond this are dropped (after the last requested tap)
    """
    n = x.shape[0]
    n_ctrl = path.shape[0]
    n_bands = gain.shape[0]
    inv4pi = 1.0 / (4.0 * math.pi)
    for i in range(base.shape[0]):
        for m in range(mics.shape[0]):
            for k in range(n):
                xk = x[k]
                if xk == 0.0:
                    continue
                pos = k / hop
                c0 = int(pos)
                if c0 >= n_ctrl - 1:
                    c0 = n_ctrl - 2 if n_ctrl > 1 else 0
                f = pos - c0 if n_ctrl > 1 else 0.0
                c1 = c0 + 1 if n_ctrl > 1 else 0
                r2 = 0.0
                for d in range(3):
                    s = path[c0, d] + f * (path[c1, d] - path[c0, d])
                    diff = base[i, d] + sign[i, d] * s - mics[m, d]
                    r2 += diff * diff
                r = math.sqrt(r2)
                q = k * u + r * scale + g0
                if q > q_max:
                    continue
                b0, w0, w1, w2, w3 = lagrange4(q)
                spread = xk * inv4pi / r
                for b in range(n_bands):
                    amp = gain[b, i] * spread
                    if air_np[b] > 0.0:
                        amp *= math.exp(-air_np[b] * r)
                    grid[b, m, b0 - 1] += amp * w0
                    grid[b, m, b0] += amp * w1
                    grid[b, m, b0 + 1] += amp * w2
                    grid[b, m, b0 + 2] += amp * w3


# reassoc/contract let LLVM vectorise the three sums over directions per step (5x faster,
# results change by ~1e-15 relative: only the summation order).
@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def scattered_steps(decay, gain_prev, gain_now, inject, w, src_decay, src_coef, out):  # pragma: no cover
    """Step the scattered-energy balance of :mod:`scenesim.room.scattering` (its ``_integrate``).

    Per direction u: ``e_u <- decay_u e_u + gain_prev_u f_{k-1} + gain_now_u f_k`` with
    ``f_k = source_k + inject . e(k)`` solved per step, ``source_k = sum_v src_coef_v
    src_decay_v^k``; ``out[k] = w . e(k)`` (``out[0] = 0``).  Compiled.
    """
    n_dir = decay.shape[0]
    e = np.zeros(n_dir)
    s = src_coef.copy()
    implicit = 0.0
    for u in range(n_dir):
        implicit += inject[u] * gain_now[u]
    f_prev = 0.0
    for v in range(s.shape[0]):
        f_prev += s[v]
    for k in range(1, out.shape[0]):
        source_k = 0.0
        for v in range(s.shape[0]):
            s[v] *= src_decay[v]
            source_k += s[v]
        part = 0.0
        for u in range(n_dir):
            e[u] = decay[u] * e[u] + gain_prev[u] * f_prev
            part += inject[u] * e[u]
        f = (source_k + part) / (1.0 - implicit)
        m = 0.0
        for u in range(n_dir):
            e[u] += gain_now[u] * f
            m += w[u] * e[u]
        out[k] = m
        f_prev = f
