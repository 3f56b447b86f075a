"""Compiled (numba) frame loops of the noise-statistics stage; the numpy steps stay the reference.

* :func:`spp_frames` -- :func:`enhancers.single.spp.spp_step`'s recursion (Gerkmann & Hendriks' SPP and
  noise PSD) frame by frame and bin by bin;
* :func:`weighted_cov_frames` -- :func:`enhancers.beam.noise_stats.noise_stats_step`'s two normalised
  recursive 2x2 averages (noisy every frame, noise with the weight ``1 - p``) for an SPP known beforehand
  (the single-channel one); the multichannel SPP, which needs the noise average of the frame before,
  stays on the numpy path.

Why compiled: the reference loops over frames with ~10 small numpy calls each (~20 us a frame), 70 % of
``eb-spp``'s batch time; here each frame is a few hundred flops.  The arithmetic is the reference's
operation for operation (same order of products and sums), so the two agree to rounding
(``tests/test_noise_stats_kernel.py``: relative 1e-12).  Arrays in, arrays out, state updated in place;
the algorithms' configurations stay in their modules.  The first call compiles (``cache=True`` keeps the
machine code under ``__pycache__``): 1.4 s measured for the first compile; a new process pays 2.2 s for
its first call, imports of numpy, numba and the stage included (``python -m benchmarks.perf.enhancer_rtf
--ratio eb-spp eb-robust@1``, on the shared 2-core machine).
"""

from __future__ import annotations

import math

import numba
import numpy as np

TINY = 1e-300
EXP_MAX = 700.0


@numba.njit(cache=True)
def spp_frames(S, sigma2, p_bar, a_n, a_p, xi, odds, p_cap):  # pragma: no cover - compiled
    """SPP ``P`` and noise PSD ``out`` (``(F, K)``) of periodograms ``S (F, K)``; ``sigma2``, ``p_bar``
    ``(K,)`` updated in place (``sigma2`` already initialised by the caller)."""
    F, K = S.shape
    P = np.empty((F, K))
    out = np.empty((F, K))
    c = math.log(odds * (1.0 + xi))
    g = xi / (1.0 + xi)
    for i in range(F):
        for k in range(K):
            s = S[i, k]
            snr = s / max(sigma2[k], TINY)
            p = 1.0 / (1.0 + math.exp(min(c - snr * g, EXP_MAX)))
            p_bar[k] = a_p * p_bar[k] + (1.0 - a_p) * p
            if p_bar[k] > p_cap:
                p = min(p, p_cap)
            sigma2[k] = a_n * sigma2[k] + (1.0 - a_n) * ((1.0 - p) * s + p * sigma2[k])
            P[i, k] = p
            out[i, k] = sigma2[k]
    return P, out


@numba.njit(cache=True)
def weighted_cov_frames(Y, P, r_yy, n_yy, r_vv, n_vv, a_y, a_v, noisy=True):  # pragma: no cover - compiled
    """Normalised averages ``yy``, ``vv`` ``(F, K, 2, 2)`` of the frame vectors ``Y (F, K, 2)``: the noisy
    one with factor ``a_y``, the noise one with ``a_v + (1 - a_v) P``, and the noise one's normaliser per
    frame ``nv (F, K)``; the sums ``r_* (K, 2, 2)`` and normalisers ``n_* (K,)`` updated in place.
    ``noisy=False``: the noisy average is neither updated nor returned (``yy`` has no frames)."""
    F, K = Y.shape[0], Y.shape[1]
    yy = np.empty((F if noisy else 0, K, 2, 2), dtype=np.complex128)
    vv = np.empty((F, K, 2, 2), dtype=np.complex128)
    nv = np.empty((F, K))
    for i in range(F):
        for k in range(K):
            a = a_v + (1.0 - a_v) * P[i, k]
            n_vv[k] = a * n_vv[k] + (1.0 - a)
            iv = 1.0 / max(n_vv[k], TINY)
            nv[i, k] = n_vv[k]
            if noisy:
                n_yy[k] = a_y * n_yy[k] + (1.0 - a_y)
            iy = 1.0 / max(n_yy[k], TINY)
            for u in range(2):
                for v in range(2):
                    o = Y[i, k, u] * np.conj(Y[i, k, v])
                    r_vv[k, u, v] = a * r_vv[k, u, v] + (1.0 - a) * o
                    vv[i, k, u, v] = r_vv[k, u, v] * iv
                    if noisy:
                        r_yy[k, u, v] = a_y * r_yy[k, u, v] + (1.0 - a_y) * o
                        yy[i, k, u, v] = r_yy[k, u, v] * iy
    return yy, vv, nv
