"""Compiled (numba) per-frame closed forms of ``eb-spp``; the numpy code of :mod:`enhancers.beam.spp_eb` stays
the reference.

* :func:`prior_and_calibration` -- the start-up prior of the noise covariance (``N Phi + (1 - N) L Gamma``)
  and the calibration's one-pole average of its entries with the unfilled mass given to the diffuse
  model (``SppElkoBeamformer._with_prior`` and ``_calibration_average``);
* :func:`closed_form_frames` -- the calibrated covariance ``D^-1 Phi D^-H``, the closed-form beta and
  delay-and-sum weight, the output weights on the uncalibrated spectra and the output
  (:func:`enhancers.beam.spp_eb.closed_form_weights` and the lines around it);
* :func:`estimate_frames` -- the rear mic's response from the calibration averages
  (:func:`enhancers.beam.mic_calibration.estimate_from_averages`, which stays the reference and the
  other enhancers' path).

Why compiled: in numpy each step is a handful of array passes over ``(frames, bins, 2, 2)``
complex arrays plus einsum dispatch, ~45 % of ``eb-spp``'s batch time; here each cell is a few dozen
flops in one pass.  The arithmetic follows the reference term by term, so the two agree to rounding
(``tests/test_spp_eb_kernel.py``: relative 1e-10; alpha, a ratio whose denominator vanishes where
the two paths coincide, absolute 1e-4, measured <= 5e-6; the one-pole recursion runs as a loop here
and through ``scipy.signal.lfilter`` there).  Arrays in, arrays out.  First call: compiled once and
cached under ``__pycache__`` (``cache=True``): a new process pays 6.1 s to import this module and
compile its three kernels, 0.48 s with numba's on-disk cache (numba's import included; shared 2-core
machine at load 1.7, an empty ``NUMBA_CACHE_DIR`` for the first figure).  ``python -m
benchmarks.perf.enhancer_rtf --ratio eb-spp eb-robust@1`` prints ``eb-spp``'s first ``process`` in a new
process, ``import enhancers`` included (0.86 s from the cache, load 0.3).
"""

from __future__ import annotations

import numba
import numpy as np

TINY = 1e-300
REG = 1e-12  # enhancers.beam.spp_eb._REG: relative regulariser of the two least-squares ratios


@numba.njit(cache=True)
def _before(prev, vv, n_prev, nv, i, k):  # pragma: no cover - compiled
    """The noise average of the frames before frame ``i``, with the start-up prior's mass
    ``(p00, p11, p10, N, fill)``: row ``i - 1`` of ``vv``/``nv``, or ``prev``/``n_prev`` for ``i = 0``."""
    if i == 0:
        a00, a11, a10, n = prev[k, 0, 0], prev[k, 1, 1], prev[k, 1, 0], n_prev[k]
    else:
        a00, a11, a10, n = vv[i - 1, k, 0, 0], vv[i - 1, k, 1, 1], vv[i - 1, k, 1, 0], nv[i - 1, k]
    fill = (1.0 - n) * 0.5 * (a00.real + a11.real)
    return n * a00 + fill, n * a11 + fill, n * a10, fill


@numba.njit(cache=True)
def prior_and_calibration(prev, vv, n_prev, nv, coh, lam, C_prev, missing):  # pragma: no cover - compiled
    """``(cal (F, 3, K), C_last (3, K), missing_last)``: the calibration's one-pole average (factor ``lam``
    > 0, last value ``C_prev (3, K)``, unfilled mass ``missing``) of the prior-filled noise covariance of the
    frames before each frame (:func:`_before`; ``prev (K, 2, 2)``, ``vv (F, K, 2, 2)``, normalisers
    ``n_prev (K,)``, ``nv (F, K)``, diffuse coherence ``coh (K,)``)."""
    F, K = nv.shape
    cal = np.empty((F, 3, K), dtype=np.complex128)
    C = C_prev.copy()
    m = missing
    for i in range(F):
        m = m * lam
        for k in range(K):
            p00, p11, p10, fill = _before(prev, vv, n_prev, nv, i, k)
            p10 = p10 + fill * coh[k]
            C[0, k] = (1.0 - lam) * p00 + lam * C[0, k]
            C[1, k] = (1.0 - lam) * p11 + lam * C[1, k]
            C[2, k] = (1.0 - lam) * p10 + lam * C[2, k]
            level = 0.5 * (p00.real + p11.real)
            cal[i, 0, k] = C[0, k] + m * level
            cal[i, 1, k] = C[1, k] + m * level
            cal[i, 2, k] = C[2, k] + m * level * coh[k]
    return cal, C, m


@numba.njit(cache=True)
def _ls(num, den, scale, prior):  # pragma: no cover - compiled
    r = REG * scale + TINY
    return min(max((num + prior * r) / (den + r), 0.0), 1.0)


@numba.njit(cache=True)
def _quad(u0, u1, c00, c01, c10, c11, v0, v1):  # pragma: no cover - compiled
    """``Re(u^T Phi conj(v))`` of one cell."""
    cv0, cv1 = np.conj(v0), np.conj(v1)
    return (u0 * (c00 * cv0 + c01 * cv1) + u1 * (c10 * cv0 + c11 * cv1)).real


@numba.njit(cache=True)
def closed_form_frames(prev, vv, n_prev, nv, coh, inv, e, G, look, X, beta0, alpha0):  # pragma: no cover
    """``(Y (F, K), w_raw (F, K, 2), beta (F, K), alpha (F, K))`` from the prior-filled noise covariance of
    the frames before each frame (:func:`_before`), the rear mic's inverse response ``inv (F, K)``, the
    design's ``e``, ``G``, ``look`` ``(K,)`` and the frames ``X (2, F, K)``; ``beta0``, ``alpha0`` the priors
    of the two least-squares ratios."""
    F, K = inv.shape
    Y = np.empty((F, K), dtype=np.complex128)
    w_raw = np.empty((F, K, 2), dtype=np.complex128)
    beta = np.empty((F, K))
    alpha = np.empty((F, K))
    for i in range(F):
        for k in range(K):
            # the prior-filled covariance again (prior_and_calibration made it too): a few flops per cell,
            # cheaper than writing and re-reading an (F, K, 2, 2) complex array (measured)
            p00, p11, p10, fill = _before(prev, vv, n_prev, nv, i, k)
            p10 = p10 + fill * coh[k]
            q = inv[i, k]
            c00 = p00
            c01 = np.conj(p10) * np.conj(q)  # the covariance is Hermitian: Phi_01 = conj(Phi_10)
            c10 = p10 * q
            c11 = p11 * (abs(q) ** 2)
            ek = e[k]
            scale = abs(c00) + abs(c11)
            # a = (1, -e), b = (-e, 1): the forward and backward cardioids
            b_ = _ls(_quad(1.0, -ek, c00, c01, c10, c11, -ek, 1.0),
                     _quad(-ek, 1.0, c00, c01, c10, c11, -ek, 1.0), scale, beta0)
            d0 = G[k] * (1.0 + b_ * ek)
            d1 = G[k] * (-ek - b_)
            s0 = 0.5 * look[k] * ek
            s1 = 0.5 * look[k]
            f0, f1 = d0 - s0, d1 - s1
            a_ = _ls(_quad(d0, d1, c00, c01, c10, c11, f0, f1),
                     _quad(f0, f1, c00, c01, c10, c11, f0, f1), scale, alpha0)
            w0 = d0 - a_ * f0
            w1 = (d1 - a_ * f1) * q
            w_raw[i, k, 0] = w0
            w_raw[i, k, 1] = w1
            Y[i, k] = w0 * X[0, i, k] + w1 * X[1, i, k]
            beta[i, k] = b_
            alpha[i, k] = a_
    return Y, w_raw, beta, alpha


@numba.njit(cache=True)
def _slope(s21, i, k0, k1, max_slope):  # pragma: no cover - compiled
    """``mic_calibration._propagation_slope`` of row ``i`` over bins ``k0 .. k1 - 1``."""
    acc = 0j
    for k in range(k0, k1 - 1):
        acc += s21[i, k + 1] * np.conj(s21[i, k])
    b0 = np.angle(acc)
    kl = float(k1 - 1)
    wmax = 0.0
    for k in range(k0, k1):
        wmax = max(wmax, abs(s21[i, k]))
    M = np.zeros((3, 3))
    rhs = np.zeros(3)
    col = np.empty(3)
    for k in range(k0, k1):
        w = abs(s21[i, k]) / (wmax + TINY)
        psi = np.angle(s21[i, k] * np.exp(-1j * b0 * k))
        col[0], col[1], col[2] = 1.0, k / kl, k0 / float(k)
        for u in range(3):
            rhs[u] += w * col[u] * psi
            for v in range(3):
                M[u, v] += w * col[u] * col[v]
    for u in range(3):
        M[u, u] += 1e-9
    coef = np.linalg.solve(M, rhs)
    return min(max(b0 + coef[1] / kl, -max_slope), max_slope)


@numba.njit(cache=True)
def _smooth_row(x, half, out):  # pragma: no cover - compiled
    """``mic_calibration._smooth_bins`` of one row ``x (K,)`` into ``out``."""
    K = x.shape[0]
    cs = np.zeros(K + 1, dtype=x.dtype)
    for k in range(K):
        cs[k + 1] = cs[k] + x[k]
    for k in range(K):
        lo = max(k - half[k], 0)
        hi = min(k + half[k] + 1, K)
        out[k] = (cs[hi] - cs[lo]) / (hi - lo)


@numba.njit(cache=True)
def estimate_frames(avg, k0, k1, max_slope, half, max_gain_db, max_phase_rad, min_coherence,
                    prev_phase, phase_leak):  # pragma: no cover - compiled
    """``r_hat (F, K)`` of :func:`enhancers.beam.mic_calibration.estimate_from_averages` for averages ``avg
    (F, 3, K)``, the fit band ``k0 .. k1 - 1``, per-bin half widths ``half (K,)`` (``min_coherence > 0``:
    the phase is held from the last coherent row, from ``prev_phase (K,)`` before any)."""
    F, K = avg.shape[0], avg.shape[2]
    r = np.empty((F, K), dtype=np.complex128)
    last = prev_phase.copy()
    age = np.zeros(K)
    derot = np.empty(K, dtype=np.complex128)
    sd = np.empty(K, dtype=np.complex128)
    s11 = np.empty(K)
    s22 = np.empty(K)
    raw11 = np.empty(K)
    raw22 = np.empty(K)
    s21 = avg[:, 2, :]
    g_hi = 10.0 ** (max_gain_db / 20.0)
    g_lo = 1.0 / g_hi
    for i in range(F):
        b = _slope(s21, i, k0, k1, max_slope)
        rot = np.exp(-1j * b)
        z = 1.0 + 0j
        for k in range(K):
            derot[k] = s21[i, k] * z  # e^{-j b k} by recurrence: one complex product a bin
            z = z * rot
            raw11[k] = avg[i, 0, k].real
            raw22[k] = avg[i, 1, k].real
        _smooth_row(derot, half, sd)
        _smooth_row(raw11, half, s11)
        _smooth_row(raw22, half, s22)
        for k in range(K):
            # 10^(clip(10 lg ratio) / 20) = clip(sqrt(ratio)): no logarithm
            g = min(max(np.sqrt((s22[k] + TINY) / (s11[k] + TINY)), g_lo), g_hi)
            ph = min(max(np.angle(sd[k]), -max_phase_rad), max_phase_rad)
            if min_coherence > 0:
                if abs(sd[k]) >= min_coherence * np.sqrt(s11[k] * s22[k]):
                    last[k] = ph
                    age[k] = 0.0
                else:
                    age[k] += 1.0
                ph = last[k] * phase_leak ** age[k]
            r[i, k] = g * complex(np.cos(ph), np.sin(ph))
    return r
