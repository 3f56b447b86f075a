"""Compiled (numba) per-block steps of the streaming enhancers: differential pair, WOLA gains, FIR pair.

Why compiled: a 10 ms block is 160 samples (1-2 frames of the 8 ms-hop filter bank), and the
numpy step spends it on 20-40 small array calls of 1-5 us dispatch each, which the batch path
pays once per signal.  One kernel call per block touches each sample once and allocates only
its outputs.  The numpy steps stay as the reference: every enhancer runs its kernel for blocks
of at most :data:`MAX_BLOCK` samples (the Martin 2001 tracker: runs of at most 4 frames) and
its numpy step for longer ones (batch), so batch == concatenated streaming is also a check of
the kernel against the reference, and ``tests/test_stream_kernels.py`` compares the two paths
on random multi-block input (1e-12 relative).  ``MAX_BLOCK = 0`` routes every block through
the numpy reference.  ``ss_block`` and ``beam_block`` also run the WOLA filter bank inside the call
(the FFT kernels of :mod:`enhancers.kernels.wola`, shared with :mod:`enhancers.kernels.frames`).

``cache=True`` keeps the machine code under ``__pycache__`` (or ``$NUMBA_CACHE_DIR``), so only
the first call in a fresh install pays the JIT (measured by ``benchmarks/perf/stream_jit.py``).
The module is imported lazily by the enhancers (importing numba costs ~0.3 s).

States are updated in place (the enhancer contract allows it): arrays passed as ``hist``,
``zi``, ``ghist``, ``P``, ``actmin``, ``ring`` are overwritten with the state after the block,
and the scalars in ``sc`` likewise.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from enhancers.kernels.wola import analyze_pair, block_frames, finish_block, synthesize_frames

__all__ = ["MAX_BLOCK", "beam_block", "differential_block", "extend", "fir_pair_block", "ms2001_frames", "ss_block",
           "ss_ms1994_frames", "warm_up"]

#: Longest block (samples) run through the compiled steps; longer blocks (batch) take the numpy path.
MAX_BLOCK = 4096

TINY = 1e-300

#: ``mode`` of :func:`differential_block`.
FIXED, BLOCK_NLMS, SAMPLE_NLMS = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _clip(v, lo, hi):  # pragma: no cover - compiled
    return lo if v < lo else (hi if v > hi else v)


def extend(hist: np.ndarray, block: np.ndarray) -> np.ndarray:
    """``[hist | block]`` per row: a new C-contiguous writable float64 array, ``(rows, H + n)``.

    The kernels take this rather than the block so that one compiled specialisation serves every
    block (a strided slice, a read-only array and a contiguous one are distinct numba types,
    each compiled on its first call).

    >>> extend(np.zeros((2, 1)), np.ones((2, 2))).tolist()
    [[0.0, 1.0, 1.0], [0.0, 1.0, 1.0]]
    """
    return np.concatenate([hist, block], axis=1)


@numba.njit(cache=True)
def _keep_tail(ext, hist):  # pragma: no cover - compiled
    """``hist`` <- the last ``H`` columns of ``ext`` (the history for the next block)."""
    rows, H = hist.shape
    n = ext.shape[1] - H
    for c in range(rows):
        for t in range(H):
            hist[c, t] = ext[c, n + t]


@numba.njit(cache=True)
def _gate_ref(ghist, r, n_window):  # pragma: no cover - compiled
    """Reference level of the adaptation gate at a decision with ratio ``r`` (dB).

    ``min(floor, 0)``, ``floor`` = minimum of the last ``n_window`` ratios including ``r``;
    ``ghist`` holds the previous ``n_window - 1`` (oldest first, +inf before the stream
    start) and is shifted by one to take ``r``.  ``n_window`` 0: reference 0 dB; 1: ``min(r, 0)``.
    """
    if n_window == 0:
        return 0.0
    m = r
    W = ghist.shape[0]
    for i in range(W):
        if ghist[i] < m:
            m = ghist[i]
    if W > 0:
        for i in range(W - 1):
            ghist[i] = ghist[i + 1]
        ghist[W - 1] = r
    return m if m < 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def _branches(ext, h, H, start, i):  # pragma: no cover - compiled
    """``(cF, cB, p1)`` at block sample ``i`` (``branch_signals`` of :mod:`enhancers.beam.differential`)."""
    acc1 = 0.0
    acc2 = 0.0
    for j in range(h.shape[0]):
        acc1 += h[j] * ext[0, H + i - j]
        acc2 += h[j] * ext[1, H + i - j]
    p1 = ext[0, start + i]
    return p1 - acc2, ext[1, start + i] - acc1, p1


@numba.njit(cache=True, inline="always")
def _block_update(beta, s_fb, s_bb, s_11, pp, frozen):  # pragma: no cover - compiled
    """Beta after a closed adaptation block with sums ``s_*`` (``_betas_block``): ``beta keep + gain``, clipped."""
    mu, eps = pp[0], pp[1]
    den = s_bb + eps * s_11 + TINY
    gain = mu * s_fb / den
    keep = 1.0 - mu * s_bb / den
    if frozen:  # a frozen block leaves beta unchanged
        gain = 0.0
        keep = 1.0
    return _clip(beta * keep + gain, pp[2], pp[3])


@numba.njit(cache=True, inline="always")
def _gate_frozen(g_f, g_b, ghist, n_window, gate_db):  # pragma: no cover - compiled
    """The adaptation gate's decision (``ElkoBeamformer._gate``) from the smoothed powers; ``ghist`` shifted."""
    r = 10.0 * math.log10((g_f + TINY) / (g_b + TINY))
    return r > _gate_ref(ghist, r, n_window) + gate_db


@numba.njit(cache=True)
def differential_block(ext, hist, h, lat, eq_b, eq_a, zi, sc, pp, mode, gate, ghist, n_window):  # pragma: no cover
    """One block of ``y = cF - beta cB`` (+ equaliser) of :mod:`enhancers.beam.eb`; returns ``y`` ``(n,)``.

    ext : (2, H + n) = :func:`extend` ``(hist, block)``; hist : (2, H) last H input samples (updated)
    h : (m,) FIR of the delayed branch; lat : bulk delay L (samples)
    eq_b, eq_a : equaliser numerator/denominator padded to one length (``a[0] = 1``), or empty
        arrays for no equaliser; zi : its direct-form-II-transposed state (updated)
    sc : [beta, phase, s_fb, s_bb, s_11, g_f, g_b, p_b, p_1] (updated; see ``enhancers.beam.eb._DiffState``)
    pp : [mu, eps, beta_min, beta_max, block_len, lam, gate_lam, gate_db]
    mode : FIXED, BLOCK_NLMS or SAMPLE_NLMS; gate : adaptation gate on (block variant)
    ghist, n_window : the gate's running-minimum window (see :func:`_gate_ref`)

    The arithmetic is that of the numpy step (``branch_signals``, ``_betas_block`` /
    ``_betas_sample``, ``lfilter``) in the same order, except the FIR's sums.
    """
    H = hist.shape[1]
    n = ext.shape[1] - H
    _keep_tail(ext, hist)
    B, lam, g = int(pp[4]), pp[5], pp[6]
    beta, phase = sc[0], int(sc[1])
    s_fb = s_bb = s_11 = 0.0  # sums of the adaptation block being filled, from this call's samples
    g_f, g_b, p_b, p_1 = sc[5], sc[6], sc[7], sc[8]
    first_open = True
    y = np.empty(n)
    for i in range(n):
        cf, cb, p1 = _branches(ext, h, H, H - lat, i)
        y[i] = cf - beta * cb
        if mode == BLOCK_NLMS:
            s_fb += cf * cb
            s_bb += cb * cb
            s_11 += p1 * p1
            if gate:
                g_f = (1.0 - g) * (cf * cf) + g * g_f
                g_b = (1.0 - g) * (cb * cb) + g * g_b
            if (phase + i + 1) % B == 0:  # an adaptation block closes at this sample
                if first_open:  # the block that was open when the call started
                    s_fb, s_bb, s_11 = s_fb + sc[2], s_bb + sc[3], s_11 + sc[4]
                    first_open = False
                frozen = gate and _gate_frozen(g_f, g_b, ghist, n_window, pp[7])
                beta = _block_update(beta, s_fb, s_bb, s_11, pp, frozen)
                s_fb = s_bb = s_11 = 0.0
        elif mode == SAMPLE_NLMS:
            p_b = (1.0 - lam) * (cb * cb) + lam * p_b
            p_1 = (1.0 - lam) * (p1 * p1) + lam * p_1
            den = p_b + pp[1] * p_1 + TINY
            beta = _clip(beta + pp[0] * (cf - beta * cb) * cb / den, pp[2], pp[3])
    if mode == BLOCK_NLMS:
        if first_open:
            s_fb, s_bb, s_11 = s_fb + sc[2], s_bb + sc[3], s_11 + sc[4]
        sc[1], sc[2], sc[3], sc[4], sc[5], sc[6] = (phase + n) % B, s_fb, s_bb, s_11, g_f, g_b
    sc[0], sc[7], sc[8] = beta, p_b, p_1
    _iir(eq_b, eq_a, y, zi)
    return y


@numba.njit(cache=True)
def _iir(b, a, x, zi):  # pragma: no cover - compiled
    """In place ``x <- lfilter(b, a, x, zi)`` (direct form II transposed, ``a[0] = 1``); ``zi`` updated.

    The order of operations is scipy's (``y = z0 + b0 x``; ``z_k = z_{k+1} + b_{k+1} x - a_{k+1} y``).
    Empty ``b`` leaves ``x`` unchanged.
    """
    order = b.shape[0] - 1
    if order < 0:
        return
    for i in range(x.shape[0]):
        xi = x[i]
        yi = zi[0] + b[0] * xi if order > 0 else b[0] * xi
        for k in range(order - 1):
            zi[k] = zi[k + 1] + xi * b[k + 1] - yi * a[k + 1]
        if order > 0:
            zi[order - 1] = xi * b[order] - yi * a[order]
        x[i] = yi


@numba.njit(cache=True)
def fir_pair_block(ext, hist, h):  # pragma: no cover - compiled
    """``y[i] = sum_c sum_j h[c, j] ext[c, H + i - j]`` over ``ext = [hist | block]`` (``(n,)``); ``hist`` updated.

    The two-channel FIR of :class:`enhancers.beam.baselines.DelayAndSum` (``H = n_taps - 1``).
    """
    H = hist.shape[1]
    n = ext.shape[1] - H
    _keep_tail(ext, hist)
    m = h.shape[1]
    y = np.empty(n)
    for i in range(n):
        acc0 = 0.0
        acc1 = 0.0
        for j in range(m):
            acc0 += h[0, j] * ext[0, H + i - j]
            acc1 += h[1, j] * ext[1, H + i - j]
        y[i] = acc0 + acc1
    return y


@numba.njit(cache=True, inline="always")
def _berouti_gain(s, ref, pn, gp):  # pragma: no cover - compiled
    """``subtraction_gain`` (:mod:`enhancers.single.ss`) of one bin: power ``s``, SNR reference ``ref``, noise ``pn``."""
    osub0, slope, osub_min, osub_max, subf, gain_max = gp[2], gp[3], gp[4], gp[5], gp[6], gp[7]
    x_mag = math.sqrt(s)
    snr_db = 10.0 * math.log10((ref if ref > TINY else TINY) / (pn if pn > TINY else TINY))
    osub = _clip(osub0 - slope * snr_db, osub_min, osub_max)
    pn_pos = pn if pn > 0.0 else 0.0
    if gp[11] != 0.0:  # power subtraction
        y_mag = math.sqrt(max(x_mag * x_mag - osub * pn_pos, subf * subf * pn_pos))
    else:
        root_pn = math.sqrt(pn_pos)
        y_mag = max(x_mag - math.sqrt(osub) * root_pn, subf * root_pn)
    return y_mag / max(max(x_mag, y_mag / gain_max), TINY)


@numba.njit(cache=True, inline="always")
def _ring_min(ring, k):  # pragma: no cover - compiled
    m = ring[0, k]
    for w in range(1, ring.shape[0]):
        if ring[w, k] < m:
            m = ring[w, k]
    return m


@numba.njit(cache=True, inline="always")
def _bin_mean(s, k, h):  # pragma: no cover - compiled
    """``enhancers.single.ss.average_over_bins`` of bin ``k`` (``s``: one frame's ``|X|^2`` or gain, mirrored ends)."""
    K = s.shape[0]
    acc = 0.0
    for j in range(-h, h + 1):
        i = abs(k + j)
        if i > K - 1:
            i = 2 * (K - 1) - i
        acc += s[i]
    return acc / (2 * h + 1)


@numba.njit(cache=True)
def ss_ms1994_frames(X, P, actmin, ring, sc, g_prev, omin, gp, smoothed):  # pragma: no cover - compiled
    """Martin 1994 tracker and Berouti gain (:mod:`enhancers.single.ss`) applied to frames ``X`` (``(F, K)`` complex).

    P, actmin : (K,) smoothed power of the last frame and the open sub-window's minimum (updated)
    ring : (W, K) minima of the last W sub-windows, oldest first (updated)
    sc : [count, has_P] frames in the open sub-window; 0 before the first frame (updated)
    g_prev : (K,) the last frame's gain (``gain_smooth``'s recursion; read when has_P, updated)
    omin : (K,) bias compensation
    gp : [alpha, sub_len, osub0, osub_slope, osub_min, osub_max, subf, gain_max, power_bins, gain_bins, gain_smooth,
          power] (power: 1 for power subtraction, 0 for magnitude)
    smoothed : SNR from the smoothed power P (else from |X|^2)

    ``X`` is overwritten with ``G X`` (the frames to synthesise), the arithmetic of
    ``_ms1994_one_frame``, ``average_over_bins``, ``subtraction_gain`` and ``smooth_gain`` per frame.
    """
    F, K = X.shape
    W = ring.shape[0]
    alpha, sub_len = gp[0], int(gp[1])
    hp, hg, beta = int(gp[8]), int(gp[9]), gp[10]
    count = int(sc[0])
    s = np.empty(K)
    g0 = np.empty(K)
    for f in range(F):
        first = sc[1] == 0.0
        count += 1
        close = count == sub_len
        for k in range(K):
            s[k] = X[f, k].real * X[f, k].real + X[f, k].imag * X[f, k].imag
        for k in range(K):
            p = (1.0 - alpha) * s[k] + alpha * (s[k] if first else P[k])
            P[k] = p
            a = actmin[k] if actmin[k] < p else p
            if close:  # the sub-window completes: its minimum enters the ring
                for w in range(W - 1):
                    ring[w, k] = ring[w + 1, k]
                ring[W - 1, k] = a
                pmin = _ring_min(ring, k)
                actmin[k] = np.inf
            else:
                pmin = min(_ring_min(ring, k), a)
                actmin[k] = a
            g0[k] = _berouti_gain(s[k] if hp == 0 else _bin_mean(s, k, hp), p if smoothed else s[k], omin[k] * pmin, gp)
        for k in range(K):
            g = g0[k] if hg == 0 else _bin_mean(g0, k, hg)
            if beta != 0.0 and not first:
                g = beta * g_prev[k] + (1.0 - beta) * g
            g_prev[k] = g
            X[f, k] = g * X[f, k]
        if close:
            count = 0
        sc[1] = 1.0
    sc[0] = count


@numba.njit(cache=True)
def ss_block(block, tail, ola, queue, wst, win, rev, tw, P, actmin, ring, sc, g_prev, omin, gp,
             smoothed):  # pragma: no cover - compiled; tests/test_stream_kernels.py compares it with numpy
    """``ss``'s streaming block ``(1, b)`` end to end: the filter bank's analysis, :func:`ss_ms1994_frames`,
    synthesis and overlap-add (the WOLA kernels of :mod:`enhancers.kernels.wola`, ``N`` a power of two).

    Returns the ``(1, b)`` output; the filter-bank state ``tail (1, N - 1)``, ``ola (1, N - R)``,
    ``queue (1, R)``, ``wst`` (as ``enhancers.kernels.robust.run_block``'s) and the tracker's
    (as :func:`ss_ms1994_frames`') are updated in place.  Consecutive frames share one complex FFT.
    """
    n = win.shape[1]
    r = wst[2]
    ext, first_end, m = block_frames(block, tail, wst)
    X = np.empty((m + 1, n // 2 + 1), dtype=np.complex128)  # one spare row: an odd frame's FFT partner
    for j in range(0, m, 2):
        e = first_end + j * r
        f = e + r if j + 1 < m else e
        analyze_pair(ext[0, e:e + n], ext[0, f:f + n], win[0], rev, tw, X[j], X[j + 1])
    ss_ms1994_frames(X[:m], P, actmin, ring, sc, g_prev, omin, gp, smoothed)  # X <- G X
    return finish_block(ext, synthesize_frames(X, m, win[1], rev, tw, ola, queue, wst), m, tail, queue, wst)


@numba.njit(cache=True)
def beam_block(block, tail, ola, queue, wst, win, rev, tw,
               wc):  # pragma: no cover - compiled; tests/test_stream_kernels.py compares it with numpy
    """A fixed beamformer's streaming block ``(2, b)`` -> ``(1, b)``: the filter bank's analysis (the two
    channels of a frame share one complex FFT), ``Y = wc[0] X[0] + wc[1] X[1]`` per bin (``wc (2, K)``),
    synthesis (two frames per inverse FFT) and overlap-add; state as :func:`ss_block`'s, ``tail (2, N - 1)``.
    """
    n = win.shape[1]
    K = n // 2 + 1
    r = wst[2]
    ext, first_end, m = block_frames(block, tail, wst)
    X = np.empty((2, K), dtype=np.complex128)
    Y = np.empty((m + 1, K), dtype=np.complex128)  # one spare row: an odd frame's inverse-FFT partner
    for j in range(m):
        e = first_end + j * r
        analyze_pair(ext[0, e:e + n], ext[1, e:e + n], win[0], rev, tw, X[0], X[1])
        for k in range(K):
            Y[j, k] = wc[0, k] * X[0, k] + wc[1, k] * X[1, k]
    return finish_block(ext, synthesize_frames(Y, m, win[1], rev, tw, ola, queue, wst), m, tail, queue, wst)


@numba.njit(cache=True, inline="always")
def _ms2001_smooth(s, p, sn2, pb, pb2, qeqi, ac, t, cp):  # pragma: no cover - compiled
    """Equations (3), (9)-(12), (20)-(23) for one frame ``s`` (K,): ``p``, ``pb``, ``pb2``, ``qeqi`` updated.

    Returns ``(ac, qiav)``; ``sn2`` (the previous noise estimate) is read only.
    """
    K = s.shape[0]
    aca, amax, aminh, bmax, snrexp, qeqimax, qeqimin = cp[0], cp[1], cp[2], cp[3], cp[4], cp[11], cp[12]
    sum_y = 0.0
    sum_sn2 = 0.0
    sum_p = 0.0
    for k in range(K):
        sum_y += s[k]
        sum_sn2 += sn2[k]
        sum_p += p[k]
    ratio = min(sum_p / max(sum_y, TINY), 1e100)  # bounded: a silent frame must not overflow
    acb = 1.0 / (1.0 + (ratio - 1.0) ** 2)                                            # (9)
    ac = aca * ac + (1.0 - aca) * max(acb, aca)                                        # (10)
    floor_ah = min(aminh, max(sum_p / max(sum_sn2, TINY), TINY) ** snrexp)            # (12)
    qsum = 0.0
    for k in range(K):
        a = max(amax * ac / (1.0 + (p[k] / max(sn2[k], TINY) - 1.0) ** 2), floor_ah)  # (11)
        pk = a * p[k] + (1.0 - a) * s[k]                                                # (3)
        p[k] = pk
        b = min(a * a, bmax)
        pb[k] = b * pb[k] + (1.0 - b) * pk                                              # (20)
        pb2[k] = b * pb2[k] + (1.0 - b) * (pk * pk)                                     # (21)
        q = min((pb2[k] - pb[k] * pb[k]) / max(2.0 * (sn2[k] * sn2[k]), TINY), qeqimax)
        qeqi[k] = max(q, qeqimin / t)                                                   # (23)
        qsum += qeqi[k]
    return ac, qsum / K


@numba.njit(cache=True, inline="always")
def _ms2001_candidates(p, qeqi, qiav, actmin, actminsub, kmod, cp):  # pragma: no cover - compiled
    """Bias-compensated candidates (17) against the sub-window minimum: ``actmin``, ``actminsub``, ``kmod`` updated."""
    nv, nd, md, mv, av = int(cp[5]), int(cp[7]), cp[8], cp[9], cp[10]
    bc = 1.0 + av * math.sqrt(qiav)
    for k in range(p.shape[0]):
        bmind = 1.0 + 2.0 * (nd - 1) * (1.0 - md) / (1.0 / qeqi[k] - 2.0 * md)       # (17)
        bminv = 1.0 + 2.0 * (nv - 1) * (1.0 - mv) / (1.0 / qeqi[k] - 2.0 * mv)
        cand = bc * p[k] * bmind
        kmod[k] = cand < actmin[k]
        if kmod[k]:
            actmin[k] = cand
            actminsub[k] = bc * p[k] * bminv


@numba.njit(cache=True, inline="always")
def _ms2001_switch(qiav, actmin, actminsub, pminu, actbuf, lminflag, kmod, ibuf, qith, nsms):  # pragma: no cover
    """End of a sub-window: the buffer switch with local-minimum acceptance; returns the new ``ibuf``."""
    nu = actbuf.shape[0]
    ibuf = ibuf % nu + 1
    j = 0
    while j < qith.shape[0] - 1 and not qiav < qith[j]:  # qith ends with +inf
        j += 1
    nsm = nsms[j]
    for k in range(actmin.shape[0]):
        actbuf[ibuf - 1, k] = actmin[k]
        m = actbuf[0, k]
        for i in range(1, nu):
            if actbuf[i, k] < m:
                m = actbuf[i, k]
        if lminflag[k] and not kmod[k] and actminsub[k] < nsm * m and actminsub[k] > m:
            m = actminsub[k]
            for i in range(nu):
                actbuf[i, k] = m
        pminu[k] = m
        lminflag[k] = False
        actmin[k] = np.inf
    return ibuf


@numba.njit(cache=True)
def ms2001_frames(S, p, sn2, pb, pb2, pminu, actmin, actminsub, actbuf, lminflag, sc, cp, qith, nsms):  # pragma: no cover
    """Martin 2001 tracker (:func:`enhancers.single.noise_tracking.ms2001_step`) for frames ``S`` ``(F, K)``.

    p, sn2, pb, pb2, pminu, actmin, actminsub : (K,) ; actbuf : (nu, K) ; lminflag : (K,) bool --
        the state after the first frame's initialisation, every array distinct (updated)
    sc : [ac, subwc, ibuf, t] (updated)
    cp : [aca, amax, aminh, bmax, snrexp, nv, nu, nd, md, mv, av, qeqimax, qeqimin]
    qith, nsms : thresholds of the mean inverse degrees of freedom and their noise-slope factors

    Returns ``(P, Pn)``, each ``(F, K)``.  The arithmetic of the numpy loop, bin by bin; its sums
    over bins run in index order here (numpy sums pairwise), a difference of rounding only.
    """
    F, K = S.shape
    nv = int(cp[5])
    ac, subwc, ibuf, t = sc[0], int(sc[1]), int(sc[2]), int(sc[3])
    pout = np.empty((F, K))
    out = np.empty((F, K))
    qeqi = np.empty(K)
    kmod = np.empty(K, dtype=np.bool_)
    for f in range(F):
        t += 1
        ac, qiav = _ms2001_smooth(S[f], p, sn2, pb, pb2, qeqi, ac, t, cp)
        _ms2001_candidates(p, qeqi, qiav, actmin, actminsub, kmod, cp)
        if 1 < subwc < nv:  # middle of a sub-window: allow a local minimum
            for k in range(K):
                lminflag[k] = lminflag[k] or kmod[k]
                pminu[k] = min(actminsub[k], pminu[k])
                sn2[k] = pminu[k]
        elif subwc >= nv:  # end of a sub-window: buffer switch
            ibuf = _ms2001_switch(qiav, actmin, actminsub, pminu, actbuf, lminflag, kmod, ibuf, qith, nsms)
            subwc = 0
        subwc += 1
        out[f] = sn2
        pout[f] = p
    sc[0], sc[1], sc[2], sc[3] = ac, subwc, ibuf, t
    return pout, out


def warm_up() -> None:
    """Compile (or load from the cache) the kernels for the argument types the enhancers pass.

    Martin 2001's loop is compiled by :func:`enhancers.single.noise_tracking.warm_up`, which owns
    its state (a kernel imports nothing above ``enhancers.core``).

    A stream that must not pay the JIT inside its first block calls this first (seconds with an
    empty cache, well under one with a warm one: ``benchmarks/perf/stream_jit.py``).

    >>> warm_up()
    """
    x = np.random.default_rng(0).standard_normal((2, 40))
    pp = np.array([0.05, 1e-6, 0.0, 1.0, 16.0, 0.99, 0.99, 3.0])
    hist = np.zeros((2, 33))
    differential_block(extend(hist, x), hist, np.ones(33) / 33, 16, np.ones(3), np.zeros(3), np.zeros(2),
                       np.zeros(9), pp, BLOCK_NLMS, True, np.full(4, np.inf), 5)
    hist = np.zeros((2, 31))
    fir_pair_block(extend(hist, x), hist, np.ones((2, 32)))
    gp = np.array([0.9, 4.0, 4.0, 0.15, 1.0, 4.75, 0.02, 1.0, 0.0, 0.0, 0.0, 0.0])
    ss_ms1994_frames(np.fft.rfft(x, axis=-1), np.zeros(21), np.full(21, np.inf), np.full((3, 21), np.inf),
                     np.zeros(2), np.zeros(21), np.ones(21), gp, True)
    from enhancers.core.filterbank import FilterBank
    from enhancers.kernels.frames import wola_state

    fb = FilterBank(frame_len=32, hop=16)
    ss_block(x[:1].copy(), *wola_state(fb, 1, n_in=1), np.zeros(17), np.full(17, np.inf), np.full((3, 17), np.inf),
             np.zeros(2), np.zeros(17), np.ones(17), gp, True)
    beam_block(x.copy(), *wola_state(fb, 1), np.ones((2, 17), dtype=complex))
