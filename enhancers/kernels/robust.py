"""Compiled (numba) frame loop of ``mic-calibration``, ``eb-subband`` and ``eb-robust``.

:func:`run_frames` is the numpy reference of :mod:`enhancers.beam.mic_calibration` (its cardioid freeze
rules, the per-bin averages and the estimate every ``estimate_every`` frames) followed by the one of
:mod:`enhancers.beam.subband_eb` (NLMS beta with its gate, the equaliser, the DAS mix weight), written
frame by frame and bin by bin.  Why compiled: streaming in 10 ms blocks sends one or two frames per
call through ~150 small numpy calls (~2 ms of Python per block); here one call does a block.  The
arithmetic follows the reference operation for operation (numpy's pairwise sum, complex division,
``uniform_filter1d``'s running sum), so the two agree to rounding (the 3x3 solve and the einsum sums
of the slope fit are the only reordered sums).  The running minimum of the freeze rules' floors is a
monotone deque per bin (exact, O(1) per frame) instead of the reference's window of ratios.

Layout (built by :mod:`enhancers.kernels.frames`, which documents each row): ``par`` float and ``ipar``
int parameters, ``cst`` / ``icst`` per-bin constants ``(rows, K)``, the state ``rs`` (real rows),
``cs`` (complex rows) and the deques ``dq_val`` / ``dq_idx`` ``(3, K, n)``, ``dq_hs`` ``(3, 2, K)``
(head, size), all updated in place.  ``cache=True`` keeps the machine code under ``__pycache__``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from enhancers.kernels.wola import (
    analyze_pair,
    block_frames,
    finish_block,
    output_buffer,
    overlap_add,
    synthesize,
)

TINY = 1e-300

# ipar slots
I_CAL, I_BEAM, I_LO, I_HI, I_NWC, I_EVERY, I_GATE, I_NWG, I_MIX, I_MIXH, I_EQ, I_NOISE, I_PHASE, I_HP, \
    I_NFRAMES = range(15)
N_IPAR = 15
# par slots
P_GL, P_THR_BIN, P_THR_BAND, P_CMIN, P_MAXSLOPE, P_MAXGAIN, P_MAXPHASE, P_MINCOH, P_LEAK, P_MU, P_LAM, \
    P_EPS, P_GLAM, P_THR_GATE, P_MIXLAM, P_ALPHA0, P_BOUND = range(17)
N_PAR = 17
# rs rows (real state per bin)
R_COUNTS, R_QB, R_QW, R_BETA, R_PB, R_P1, R_GATE, R_SYD, R_SDD, R_SM = 0, 1, 3, 5, 6, 7, 8, 10, 11, 12
N_RS = 13
# cs rows (complex state per bin)
C_AVG, C_RLAST, C_RAWLAST = 0, 3, 4
N_CS = 5
# cst rows (real per-bin constants)
K_PHR, K_PHI, K_GSTATIC, K_HPF, K_COSWT, K_LOOK2, K_INBAND = range(7)
N_CST = 7


@numba.njit(cache=True, inline="always")
def _cdiv(ar, ai, br, bi):  # pragma: no cover - compiled
    """numpy's complex division (Smith's method, times the reciprocal), so results match it bitwise."""
    if abs(br) >= abs(bi):
        rat = bi / br
        scl = 1.0 / (br + bi * rat)
        return complex((ar + ai * rat) * scl, (ai - ar * rat) * scl)
    rat = br / bi
    scl = 1.0 / (bi + br * rat)
    return complex((ar * rat + ai) * scl, (ai * rat - ar) * scl)


@numba.njit(cache=True)
def _pairwise_sum(x, lo, hi, lanes):  # pragma: no cover - compiled
    """``sum(x[lo:hi])`` in numpy's order up to 16 ``lanes`` values: ``lanes`` accumulators (8 for real
    arrays; 4 for the real or imaginary parts of a complex array, which numpy sums interleaved).
    Longer sums (numpy recurses on halves; numba's cache cannot hold a recursive function) run in
    plain order: they differ from numpy's by rounding only."""
    n = hi - lo
    if n < lanes or n > 16 * lanes:
        s = 0.0
        for i in range(lo, hi):
            s += x[i]
        return s
    r = np.empty(lanes)
    for j in range(lanes):
        r[j] = x[lo + j]
    i = lanes
    while i < n - (n % lanes):
        for j in range(lanes):
            r[j] += x[lo + i + j]
        i += lanes
    if lanes == 8:
        s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    else:
        s = (r[0] + r[1]) + (r[2] + r[3])
    while i < n:
        s += x[lo + i]
        i += 1
    return s


@numba.njit(cache=True)
def _floor_min(dq_val, dq_idx, dq_hs, g, k, t, x, n_window):  # pragma: no cover - compiled
    """Push ratio ``x`` of frame ``t`` into bin ``k``'s deque ``g``; the minimum over frames ``t - n + 1 .. t``.

    The deque (a ring of ``n_window`` slots per bin, contiguous: ``dq_val[g, k]``) holds increasing
    values of increasing frames; one push per frame, so at most the front expires."""
    vals = dq_val[g, k]
    idxs = dq_idx[g, k]
    head, size = dq_hs[g, 0, k], dq_hs[g, 1, k]
    if size > 0 and idxs[head] <= t - n_window:
        head += 1
        if head == n_window:
            head = 0
        size -= 1
    back = head + size - 1  # the last slot (head - 1 when empty)
    if back >= n_window:
        back -= n_window
    while size > 0 and vals[back] >= x:  # dominated by the new value
        size -= 1
        back -= 1
        if back < 0:
            back += n_window
    slot = back + 1
    if slot >= n_window:
        slot -= n_window
    elif slot < 0:
        slot += n_window
    vals[slot] = x
    idxs[slot] = t
    dq_hs[g, 0, k], dq_hs[g, 1, k] = head, size + 1
    return vals[head]


@numba.njit(cache=True)
def _gate(eF, eB, rs, row, lam, thr, dq_val, dq_idx, dq_hs, g, t, n_window, frozen):  # pragma: no cover - compiled
    """stft_stage.power_ratio_gate for one frame (cap 1): ``frozen[k] |= r > min(floor, 1) thr``;
    ``rs[row:row + 2]`` = smoothed P_F, P_B."""
    b = 1.0 - lam
    for k in range(eF.shape[0]):
        pf = b * eF[k] + lam * rs[row, k]
        pb = b * eB[k] + lam * rs[row + 1, k]
        rs[row, k], rs[row + 1, k] = pf, pb
        r = (pf + TINY) / (pb + TINY)
        if n_window > 0:
            ref = min(_floor_min(dq_val, dq_idx, dq_hs, g, k, t, r, n_window), 1.0)
        else:
            ref = 1.0
        if r > ref * thr:
            frozen[k] = True


@numba.njit(cache=True)
def _cal_freeze(x1, x2, par, ipar, cst, rs, dq_val, dq_idx, dq_hs, t, card):  # pragma: no cover - compiled
    """The calibration's two cardioid rules for one frame (mic_calibration._freeze): ``card (K,)``."""
    K = x1.shape[0]
    eF = np.empty(K)
    eB = np.empty(K)
    for k in range(K):
        ph = complex(cst[K_PHR, k], cst[K_PHI, k])
        cf = x1[k] - ph * x2[k]
        cb = x2[k] - ph * x1[k]
        eF[k] = cf.real * cf.real + cf.imag * cf.imag
        eB[k] = cb.real * cb.real + cb.imag * cb.imag
    nF = np.empty(K)  # neighbours 2 and 3 bins away (mic_calibration._shift_sum's order)
    nB = np.empty(K)
    wF = np.empty(K)  # the band leaving out the bin and its neighbours (_leave_out_sum)
    wB = np.empty(K)
    totF = _pairwise_sum(eF, ipar[I_LO], ipar[I_HI], 8)
    totB = _pairwise_sum(eB, ipar[I_LO], ipar[I_HI], 8)
    for k in range(K):
        sF = 0.0
        sB = 0.0
        for o in (-3, -2, 2, 3):
            if 0 <= k + o < K:
                sF += eF[k + o]
                sB += eB[k + o]
        nF[k], nB[k] = sF, sB
        sF = 0.0
        sB = 0.0
        for o in (-1, 0, 1):
            if 0 <= k + o < K:
                sF += eF[k + o] * cst[K_INBAND, k + o]
                sB += eB[k + o] * cst[K_INBAND, k + o]
        wF[k], wB[k] = totF - sF, totB - sB
        card[k] = False
    nw, gl = ipar[I_NWC], par[P_GL]
    _gate(nF, nB, rs, R_QB, gl, par[P_THR_BIN], dq_val, dq_idx, dq_hs, 0, t, nw, card)
    _gate(wF, wB, rs, R_QW, gl, par[P_THR_BAND], dq_val, dq_idx, dq_hs, 1, t, nw, card)


@numba.njit(cache=True)
def _slope(s21, lo, hi, max_slope):  # pragma: no cover - compiled
    """mic_calibration._propagation_slope for one frame: lag-one guess, then the weighted fit of
    ``a + b k + c / k`` (3x3 normal equations, solved with partial pivoting)."""
    n = hi - lo - 1  # the lag-one products' real and imaginary parts
    re = np.empty(n)
    im = np.empty(n)
    for j in range(n):
        z = s21[lo + j + 1] * s21[lo + j].conjugate()
        re[j], im[j] = z.real, z.imag
    b0 = math.atan2(_pairwise_sum(im, 0, n, 4), _pairwise_sum(re, 0, n, 4))
    kf, kl = float(lo), float(hi - 1)
    M = np.zeros((3, 3))
    rhs = np.zeros(3)
    wmax = 0.0
    for k in range(lo, hi):
        wmax = max(wmax, abs(s21[k]))
    for k in range(lo, hi):
        kk = float(k)
        e = complex(math.cos(b0 * kk), -math.sin(b0 * kk))
        z = s21[k] * e
        psi = math.atan2(z.imag, z.real)
        w = abs(s21[k]) / (wmax + TINY)
        a = (1.0, kk / kl, kf / kk)
        for i in range(3):
            for j in range(3):
                M[i, j] += w * a[i] * a[j]
            rhs[i] += w * a[i] * psi
    for i in range(3):
        M[i, i] += 1e-9
    for c in range(3):  # Gaussian elimination with partial pivoting (LAPACK's gesv does the same)
        p = c
        for r in range(c + 1, 3):
            if abs(M[r, c]) > abs(M[p, c]):
                p = r
        if p != c:
            for j in range(3):
                M[c, j], M[p, j] = M[p, j], M[c, j]
            rhs[c], rhs[p] = rhs[p], rhs[c]
        for r in range(c + 1, 3):
            f = M[r, c] / M[c, c]
            for j in range(c, 3):
                M[r, j] -= f * M[c, j]
            rhs[r] -= f * rhs[c]
    coef = np.zeros(3)
    for i in range(2, -1, -1):
        s = rhs[i]
        for j in range(i + 1, 3):
            s -= M[i, j] * coef[j]
        coef[i] = s / M[i, i]
    return min(max(b0 + coef[1] / kl, -max_slope), max_slope)


@numba.njit(cache=True)
def _estimate(cs, par, ipar, icst):  # pragma: no cover - compiled
    """mic_calibration.estimate_from_averages for the current averages: sets ``r_last``, ``raw_last``."""
    K = cs.shape[1]
    s21 = cs[C_AVG + 2]
    slope = _slope(s21, ipar[I_LO], ipar[I_HI], par[P_MAXSLOPE])
    c_re = np.zeros(K + 1)  # cumulative sums for the band smoothing (mic_calibration._smooth_bins)
    c_im = np.zeros(K + 1)
    c11 = np.zeros(K + 1)
    c22 = np.zeros(K + 1)
    for k in range(K):
        e = complex(math.cos(slope * k), -math.sin(slope * k))
        d = s21[k] * e
        c_re[k + 1] = c_re[k] + d.real
        c_im[k + 1] = c_im[k] + d.imag
        c11[k + 1] = c11[k] + cs[C_AVG, k].real
        c22[k + 1] = c22[k] + cs[C_AVG + 1, k].real
    mg, mp, mc, leak = par[P_MAXGAIN], par[P_MAXPHASE], par[P_MINCOH], par[P_LEAK]
    for k in range(K):
        lo, hi = icst[0, k], icst[1, k]
        n = float(hi - lo)
        d = _cdiv(c_re[hi] - c_re[lo], c_im[hi] - c_im[lo], n, 0.0)
        s11 = (c11[hi] - c11[lo]) / n
        s22 = (c22[hi] - c22[lo]) / n
        gain_db = min(max(10.0 * math.log10((s22 + TINY) / (s11 + TINY)), -mg), mg)
        phase = min(max(math.atan2(d.imag, d.real), -mp), mp)
        if mc > 0 and not abs(d) >= mc * math.sqrt(s11 * s22):  # incoherent: the last phase, fading
            last = cs[C_RAWLAST, k]
            phase = math.atan2(last.imag, last.real) * leak
        m = 10.0 ** (gain_db / 20.0)
        r = complex(m * math.cos(phase), m * math.sin(phase))
        cs[C_RAWLAST, k] = r
        cs[C_RLAST, k] = r


@numba.njit(cache=True)
def _calibrate(x1, x2, par, ipar, cst, icst, rs, cs, dq_val, dq_idx, dq_hs, t, card, r_hat,
               x2c):  # pragma: no cover - compiled
    """One frame of mic_calibration.calibration_masks_step (no level rule, no ramp): the freeze mask
    ``card``, the averages, every ``estimate_every`` frames the estimate; ``r_hat``, ``x2c = x2 / r_hat``."""
    K = x1.shape[0]
    _cal_freeze(x1, x2, par, ipar, cst, rs, dq_val, dq_idx, dq_hs, t, card)
    cmin = par[P_CMIN]
    for k in range(K):
        if card[k]:
            continue
        n = rs[R_COUNTS, k] + 1.0
        rs[R_COUNTS, k] = n
        c = max(1.0 / max(n, 1.0), cmin)
        a, b = x1[k], x2[k]
        cs[C_AVG, k] += c * ((a.real * a.real + a.imag * a.imag) - cs[C_AVG, k])
        cs[C_AVG + 1, k] += c * ((b.real * b.real + b.imag * b.imag) - cs[C_AVG + 1, k])
        cs[C_AVG + 2, k] += c * (b * a.conjugate() - cs[C_AVG + 2, k])
    if t % ipar[I_EVERY] == 0:
        _estimate(cs, par, ipar, icst)
    for k in range(K):
        r = cs[C_RLAST, k]
        r_hat[k] = r
        x2c[k] = _cdiv(x2[k].real, x2[k].imag, r.real, r.imag)


@numba.njit(cache=True)
def _box(x, h, out):  # pragma: no cover - compiled
    """scipy.ndimage.uniform_filter1d(x, 2h + 1, mode="nearest") with its running sum, bitwise."""
    K = x.shape[0]
    size = 2 * h + 1
    ext = np.empty(K + 2 * h)
    for i in range(K + 2 * h):
        ext[i] = x[min(max(i - h, 0), K - 1)]
    s = 0.0
    for i in range(size):
        s += ext[i]
    out[0] = s / size
    for i in range(1, K):
        s += ext[i + size - 1] - ext[i - 1]
        out[i] = s / size


@numba.njit(cache=True)
def _beam(x1, x2, par, ipar, cst, rs, dq_val, dq_idx, dq_hs, t, mix_frozen, y, beta, G,
          alpha):  # pragma: no cover - compiled
    """One frame of SubbandBase._beamform: beta (applied, then its NLMS update), the EQ ``G``, the DAS
    mix weight ``alpha`` (when on) and the output ``y``.  ``mix_frozen``: the calibration's mask."""
    K = x1.shape[0]
    lam, mu, eps = par[P_LAM], par[P_MU], par[P_EPS]
    b = 1.0 - lam
    cF = np.empty(K, dtype=np.complex128)
    cB = np.empty(K, dtype=np.complex128)
    eF = np.empty(K)
    eB = np.empty(K)
    p1 = np.empty(K)
    for k in range(K):
        ph = complex(cst[K_PHR, k], cst[K_PHI, k])
        cF[k] = x1[k] - ph * x2[k]
        cB[k] = x2[k] - ph * x1[k]
        eF[k] = cF[k].real * cF[k].real + cF[k].imag * cF[k].imag
        eB[k] = cB[k].real * cB[k].real + cB[k].imag * cB[k].imag
    frozen = np.zeros(K, dtype=np.bool_)
    if ipar[I_GATE]:
        _gate(eF, eB, rs, R_GATE, par[P_GLAM], par[P_THR_GATE], dq_val, dq_idx, dq_hs, 2, t,
              ipar[I_NWG], frozen)
    for k in range(K):
        pb = b * eB[k] + lam * rs[R_PB, k]
        p1[k] = b * (x1[k].real * x1[k].real + x1[k].imag * x1[k].imag) + lam * rs[R_P1, k]
        rs[R_PB, k], rs[R_P1, k] = pb, p1[k]
        w = rs[R_BETA, k]
        beta[k] = w
        if not frozen[k]:
            den = pb + eps * p1[k] + TINY
            gain = mu * (cF[k].real * cB[k].real + cF[k].imag * cB[k].imag) / den
            keep = 1.0 - mu * eB[k] / den
            rs[R_BETA, k] = max(min(w * keep + gain, 1.0), 0.0)
        g = 1.0
        if ipar[I_EQ]:
            g = cst[K_GSTATIC, k]
            if ipar[I_NOISE]:
                nf = 2.0 * (1.0 + w * w + 2.0 * w * cst[K_COSWT, k])
                g = min(g, math.sqrt(par[P_BOUND] / max(nf, 1e-30)))
            if ipar[I_HP]:
                g = g * cst[K_HPF, k]
        G[k] = complex(0.0, -g) if ipar[I_PHASE] else complex(g, 0.0)
        y[k] = G[k] * (cF[k] - w * cB[k])
    if not ipar[I_MIX]:
        return
    yd = np.empty(K)
    dd = np.empty(K)
    D = np.empty(K, dtype=np.complex128)
    for k in range(K):
        ph = complex(cst[K_PHR, k], cst[K_PHI, k])
        D[k] = y[k] - (abs(G[k]) * cst[K_LOOK2, k] * 0.5) * (x1[k] * ph + x2[k])
        yd[k] = y[k].real * D[k].real + y[k].imag * D[k].imag
        dd[k] = D[k].real * D[k].real + D[k].imag * D[k].imag
    h = ipar[I_MIXH]
    if h > 0:
        tmp = np.empty(K)
        _box(yd, h, tmp)
        yd[:] = tmp
        _box(dd, h, tmp)
        dd[:] = tmp
    c = 1.0 - par[P_MIXLAM]
    a0 = par[P_ALPHA0]
    for k in range(K):
        reg = eps * rs[R_SM, k] + TINY
        a = min(max((rs[R_SYD, k] + a0 * reg) / (rs[R_SDD, k] + reg), 0.0), 1.0)
        alpha[k] = a
        if not (frozen[k] or mix_frozen[k]):
            rs[R_SYD, k] += c * (yd[k] - rs[R_SYD, k])
            rs[R_SDD, k] += c * (dd[k] - rs[R_SDD, k])
            rs[R_SM, k] += c * (p1[k] - rs[R_SM, k])
        y[k] = y[k] - a * D[k]


@numba.njit(cache=True)
def run_frames(X1, X2, par, ipar, cst, icst, rs, cs, dq_val, dq_idx, dq_hs, out_c, out_r,
               frozen):  # pragma: no cover - compiled; covered through tests/test_fast_frames.py
    """Process frames ``X1, X2 (F, K)`` in place of the state; fills ``out_c (3, F, K)`` = (output,
    r_hat, G), ``out_r (2, F, K)`` = (beta, alpha), ``frozen (F, K)`` (the calibration's mask).

    With the calibration only (``ipar[I_BEAM] == 0``) the output is the calibrated rear mic."""
    F = X1.shape[0]
    for f in range(F):
        t = ipar[I_NFRAMES]
        x2 = X2[f]
        if ipar[I_CAL]:
            x2 = np.empty(X1.shape[1], dtype=np.complex128)
            _calibrate(X1[f], X2[f], par, ipar, cst, icst, rs, cs, dq_val, dq_idx, dq_hs, t, frozen[f],
                       out_c[1, f], x2)
            if not ipar[I_BEAM]:
                out_c[0, f] = x2
        if ipar[I_BEAM]:
            _beam(X1[f], x2, par, ipar, cst, rs, dq_val, dq_idx, dq_hs, t, frozen[f], out_c[0, f], out_r[0, f],
                  out_c[2, f], out_r[1, f])
        ipar[I_NFRAMES] = t + 1


@numba.njit(cache=True)
def run_block(block, tail, ola, queue, wst, win, rev, tw, par, ipar, cst, icst, rs, cs, dq_val, dq_idx,
              dq_hs):  # pragma: no cover - compiled; covered through tests/test_fast_frames.py
    """One streaming block ``(2, b)`` end to end: the filter bank's analysis (enhancers.core.filterbank's
    frames, windows ``win = (w_a, w_s)``), :func:`run_frames`, synthesis and overlap-add.  Returns the
    block's ``(C, b)`` output samples (``C = ola.shape[0]``: 2 = the calibrated pair, 1 = the beam).

    Filter-bank state, updated in place: ``tail (2, N - 1)`` the last input samples, ``ola (C, N - R)``
    the partial overlap-add sums, ``queue (C, R)`` completed samples not yet returned, ``wst`` =
    (samples received modulo R, queued samples, R)."""
    n = win.shape[1]
    K = n // 2 + 1
    r = wst[2]
    ext, first_end, m = block_frames(block, tail, wst)
    X = np.empty((2, m, K), dtype=np.complex128)
    for j in range(m):
        e = first_end + j * r  # the frame ending at block index e spans ext[e : e + N]
        analyze_pair(ext[0, e:e + n], ext[1, e:e + n], win[0], rev, tw, X[0, j], X[1, j])
    out_c = np.empty((3, m, K), dtype=np.complex128)
    out_r = np.empty((2, m, K))
    frozen = np.zeros((m, K), dtype=np.bool_)
    run_frames(X[0], X[1], par, ipar, cst, icst, rs, cs, dq_val, dq_idx, dq_hs, out_c, out_r, frozen)
    n_ch = ola.shape[0]
    buf = output_buffer(queue, wst, m)
    y = np.empty((2, n))
    for j in range(m):
        if n_ch == 2:  # the calibrated pair: front and corrected rear
            synthesize(X[0, j], out_c[0, j], True, win[1], rev, tw, y[0], y[1])
        else:
            synthesize(out_c[0, j], out_c[0, j], False, win[1], rev, tw, y[0], y[1])
        for c in range(n_ch):
            overlap_add(y[c], c, j, ola, buf, wst)
    return finish_block(ext, buf, m, tail, queue, wst)
