"""Compiled (numba) per-block steps of the streaming enhancers: differential pair, WOLA gains, FIR pair.

Why compiled: a 10 ms block is 160 samples (1-2 frames of the 8 ms-hop filter bank), and the
numpy step spends it on 20-40 small array calls of 1-5 us dispatch each, which the batch path
pays once per signal.  One kernel call per block touches each sample once and allocates only
its outputs.  The numpy steps stay as the reference: every enhancer runs its kernel for blocks
of at most :data:`MAX_BLOCK` samples (the Martin 2001 tracker: runs of at most 4 frames) and
its numpy step for longer ones (batch), so batch == concatenated streaming is also a check of
the kernel against the reference, and ``tests/test_stream_kernels.py`` compares the two paths
on random multi-block input (1e-12 relative).  ``MAX_BLOCK = 0`` routes every block through
the numpy reference.

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

__all__ = ["MAX_BLOCK", "differential_block", "extend", "fir_pair_block", "ms2001_frames", "ss_ms1994_frames",
           "warm_up"]

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


@numba.njit(cache=True)
def differential_block(ext, hist, h, lat, eq_b, eq_a, zi, sc, pp, mode, gate, ghist, n_window):  # pragma: no cover
    """One block of ``y = cF - beta cB`` (+ equaliser) of :mod:`enhancers.eb`; returns ``y`` ``(n,)``.

    ext : (2, H + n) = :func:`extend` ``(hist, block)``; hist : (2, H) last H input samples (updated)
    h : (m,) FIR of the delayed branch; lat : bulk delay L (samples)
    eq_b, eq_a : equaliser numerator/denominator padded to one length (``a[0] = 1``), or empty
        arrays for no equaliser; zi : its direct-form-II-transposed state (updated)
    sc : [beta, phase, s_fb, s_bb, s_11, g_f, g_b, p_b, p_1] (updated; see ``enhancers.eb._DiffState``)
    pp : [mu, eps, beta_min, beta_max, block_len, lam, gate_lam, gate_db]
    mode : FIXED, BLOCK_NLMS or SAMPLE_NLMS; gate : adaptation gate on (block variant)
    ghist, n_window : the gate's running-minimum window (see :func:`_gate_ref`)

    The arithmetic is that of the numpy step (``branch_signals``, ``_betas_block`` /
    ``_betas_sample``, ``lfilter``) in the same order, except the FIR's sums.
    """
    H = hist.shape[1]
    n = ext.shape[1] - H
    _keep_tail(ext, hist)
    m = h.shape[0]
    start = H - lat
    mu, eps, lo, hi = pp[0], pp[1], pp[2], pp[3]
    B = int(pp[4])
    lam, g, gate_db = pp[5], pp[6], pp[7]
    beta = sc[0]
    phase = int(sc[1])
    s_fb = 0.0
    s_bb = 0.0
    s_11 = 0.0
    g_f, g_b, p_b, p_1 = sc[5], sc[6], sc[7], sc[8]
    first_open = True
    y = np.empty(n)
    for i in range(n):
        acc1 = 0.0
        acc2 = 0.0
        for j in range(m):
            acc1 += h[j] * ext[0, H + i - j]
            acc2 += h[j] * ext[1, H + i - j]
        p1 = ext[0, start + i]
        cf = p1 - acc2
        cb = ext[1, start + i] - acc1
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
                    s_fb += sc[2]
                    s_bb += sc[3]
                    s_11 += sc[4]
                    first_open = False
                den = s_bb + eps * s_11 + TINY
                gain = mu * s_fb / den
                keep = 1.0 - mu * s_bb / den
                if gate:
                    r = 10.0 * math.log10((g_f + TINY) / (g_b + TINY))
                    if r > _gate_ref(ghist, r, n_window) + gate_db:
                        gain = 0.0
                        keep = 1.0
                beta = _clip(beta * keep + gain, lo, hi)
                s_fb = 0.0
                s_bb = 0.0
                s_11 = 0.0
        elif mode == SAMPLE_NLMS:
            p_b = (1.0 - lam) * (cb * cb) + lam * p_b
            p_1 = (1.0 - lam) * (p1 * p1) + lam * p_1
            den = p_b + eps * p_1 + TINY
            beta = _clip(beta + mu * (cf - beta * cb) * cb / den, lo, hi)
    if mode == BLOCK_NLMS:
        if first_open:
            s_fb += sc[2]
            s_bb += sc[3]
            s_11 += sc[4]
        sc[1] = (phase + n) % B
        sc[2], sc[3], sc[4] = s_fb, s_bb, s_11
        sc[5], sc[6] = g_f, g_b
    sc[0] = beta
    sc[7], sc[8] = p_b, p_1
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

    The two-channel FIR of :class:`enhancers.baselines.DelayAndSum` (``H = n_taps - 1``).
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


@numba.njit(cache=True)
def ss_ms1994_frames(X, P, actmin, ring, sc, omin, gp, smoothed):  # pragma: no cover - compiled
    """Martin 1994 tracker and Berouti gain (:mod:`enhancers.ss`) for frames ``X`` (``(F, K)`` complex).

    P, actmin : (K,) smoothed power of the last frame and the open sub-window's minimum (updated)
    ring : (W, K) minima of the last W sub-windows, oldest first (updated)
    sc : [count, has_P] frames in the open sub-window; 0 before the first frame (updated)
    omin : (K,) bias compensation; gp : [alpha, sub_len, osub0, osub_slope, osub_min, osub_max, subf, gain_max]
    smoothed : SNR from the smoothed power P (else from |X|^2)

    Returns ``(Y, G, Pn)``: ``G X``, the gain and the noise PSD, each ``(F, K)``; the arithmetic
    of ``_ms1994_one_frame`` and ``subtraction_gain`` per frame.
    """
    F, K = X.shape
    W = ring.shape[0]
    alpha, sub_len = gp[0], int(gp[1])
    osub0, slope, osub_min, osub_max, subf, gain_max = gp[2], gp[3], gp[4], gp[5], gp[6], gp[7]
    Y = np.empty((F, K), dtype=np.complex128)
    G = np.empty((F, K))
    Pn_out = np.empty((F, K))
    count = int(sc[0])
    for f in range(F):
        first = sc[1] == 0.0
        count += 1
        close = count == sub_len
        for k in range(K):
            xr = X[f, k].real
            xi = X[f, k].imag
            s = xr * xr + xi * xi
            p_prev = s if first else P[k]
            p = (1.0 - alpha) * s + alpha * p_prev
            P[k] = p
            a = actmin[k] if actmin[k] < p else p
            if close:  # the sub-window completes: its minimum enters the ring
                for w in range(W - 1):
                    ring[w, k] = ring[w + 1, k]
                ring[W - 1, k] = a
                pmin = ring[0, k]
                for w in range(1, W):
                    if ring[w, k] < pmin:
                        pmin = ring[w, k]
                actmin[k] = np.inf
            else:
                pmin = ring[0, k]
                for w in range(1, W):
                    if ring[w, k] < pmin:
                        pmin = ring[w, k]
                if a < pmin:
                    pmin = a
                actmin[k] = a
            pn = omin[k] * pmin
            ref = p if smoothed else s
            x_mag = math.sqrt(s)
            snr_db = 10.0 * math.log10((ref if ref > TINY else TINY) / (pn if pn > TINY else TINY))
            osub = _clip(osub0 - slope * snr_db, osub_min, osub_max)
            root_pn = math.sqrt(pn if pn > 0.0 else 0.0)
            y_mag = max(x_mag - math.sqrt(osub) * root_pn, subf * root_pn)
            gk = y_mag / max(max(x_mag, y_mag / gain_max), TINY)
            G[f, k] = gk
            Pn_out[f, k] = pn
            Y[f, k] = gk * X[f, k]
        if close:
            count = 0
        sc[1] = 1.0
    sc[0] = count
    return Y, G, Pn_out


@numba.njit(cache=True)
def ms2001_frames(S, p, sn2, pb, pb2, pminu, actmin, actminsub, actbuf, lminflag, sc, cp, qith, nsms):  # pragma: no cover
    """Martin 2001 tracker (:func:`enhancers.noise_tracking.ms2001_step`) for frames ``S`` ``(F, K)``.

    p, sn2, pb, pb2, pminu, actmin, actminsub : (K,) ; actbuf : (nu, K) ; lminflag : (K,) bool --
        the state after the first frame's initialisation, every array distinct (updated)
    sc : [ac, subwc, ibuf, t] (updated)
    cp : [aca, amax, aminh, bmax, snrexp, nv, nu, nd, md, mv, av, qeqimax, qeqimin]
    qith, nsms : thresholds of the mean inverse degrees of freedom and their noise-slope factors

    Returns ``(P, Pn)``, each ``(F, K)``.  The arithmetic of the numpy loop, bin by bin; its sums
    over bins run in index order here (numpy sums pairwise), a difference of rounding only.
    """
    F, K = S.shape
    aca, amax, aminh, bmax, snrexp = cp[0], cp[1], cp[2], cp[3], cp[4]
    nv, nu, nd, md, mv = int(cp[5]), int(cp[6]), int(cp[7]), cp[8], cp[9]
    av, qeqimax, qeqimin = cp[10], cp[11], cp[12]
    ac, subwc, ibuf, t = sc[0], int(sc[1]), int(sc[2]), int(sc[3])
    pout = np.empty((F, K))
    out = np.empty((F, K))
    ah = np.empty(K)
    qeqi = np.empty(K)
    kmod = np.empty(K, dtype=np.bool_)
    for f in range(F):
        t += 1
        sum_y = 0.0
        sum_sn2 = 0.0
        sum_p = 0.0
        for k in range(K):
            sum_y += S[f, k]
            sum_sn2 += sn2[k]
            sum_p += p[k]
        sum_y = max(sum_y, TINY)
        sum_sn2 = max(sum_sn2, TINY)
        ratio = min(sum_p / sum_y, 1e100)  # bounded: a silent frame must not overflow
        acb = 1.0 / (1.0 + (ratio - 1.0) ** 2)                                        # (9)
        ac = aca * ac + (1.0 - aca) * max(acb, aca)                                    # (10)
        snr = max(sum_p / sum_sn2, TINY)
        floor_ah = min(aminh, snr ** snrexp)                                           # (12)
        qsum = 0.0
        for k in range(K):
            a = amax * ac / (1.0 + (p[k] / max(sn2[k], TINY) - 1.0) ** 2)              # (11)
            a = max(a, floor_ah)
            ah[k] = a
            pk = a * p[k] + (1.0 - a) * S[f, k]                                         # (3)
            p[k] = pk
            b = min(a * a, bmax)
            pb[k] = b * pb[k] + (1.0 - b) * pk                                          # (20)
            pb2[k] = b * pb2[k] + (1.0 - b) * (pk * pk)                                 # (21)
            q = min((pb2[k] - pb[k] * pb[k]) / max(2.0 * (sn2[k] * sn2[k]), TINY), qeqimax)
            q = max(q, qeqimin / t)                                                     # (23)
            qeqi[k] = q
            qsum += q
        qiav = qsum / K
        bc = 1.0 + av * math.sqrt(qiav)
        for k in range(K):
            bmind = 1.0 + 2.0 * (nd - 1) * (1.0 - md) / (1.0 / qeqi[k] - 2.0 * md)       # (17)
            bminv = 1.0 + 2.0 * (nv - 1) * (1.0 - mv) / (1.0 / qeqi[k] - 2.0 * mv)
            cand = bc * p[k] * bmind
            kmod[k] = cand < actmin[k]
            if kmod[k]:
                actmin[k] = cand
                actminsub[k] = bc * p[k] * bminv
        if 1 < subwc < nv:  # middle of a sub-window: allow a local minimum
            for k in range(K):
                lminflag[k] = lminflag[k] or kmod[k]
                pminu[k] = min(actminsub[k], pminu[k])
                sn2[k] = pminu[k]
        elif subwc >= nv:  # end of a sub-window: buffer switch
            ibuf = ibuf % nu + 1
            j = 0
            while j < qith.shape[0] - 1 and not qiav < qith[j]:  # qith ends with +inf
                j += 1
            nsm = nsms[j]
            for k in range(K):
                actbuf[ibuf - 1, k] = actmin[k]
                m = actbuf[0, k]
                for i in range(1, nu):
                    if actbuf[i, k] < m:
                        m = actbuf[i, k]
                if (lminflag[k] and not kmod[k] and actminsub[k] < nsm * m and actminsub[k] > m):
                    m = actminsub[k]
                    for i in range(nu):
                        actbuf[i, k] = m
                pminu[k] = m
                lminflag[k] = False
                actmin[k] = np.inf
            subwc = 0
        subwc += 1
        for k in range(K):
            out[f, k] = sn2[k]
            pout[f, k] = p[k]
    sc[0], sc[1], sc[2], sc[3] = ac, subwc, ibuf, t
    return pout, out


def warm_up() -> None:
    """Compile (or load from the cache) every kernel for the argument types the enhancers pass.

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
    gp = np.array([0.9, 4.0, 4.0, 0.15, 1.0, 4.75, 0.02, 1.0])
    ss_ms1994_frames(np.fft.rfft(x, axis=-1), np.zeros(21), np.full(21, np.inf), np.full((3, 21), np.inf),
                     np.zeros(2), np.ones(21), gp, True)
    from enhancers.noise_tracking import MS2001Config, ms2001_init, ms2001_step

    ms2001_step(np.abs(np.fft.rfft(x, axis=-1)) ** 2, ms2001_init(), MS2001Config(frame_step_s=0.008))
