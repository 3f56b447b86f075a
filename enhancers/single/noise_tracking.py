"""Noise power spectral density trackers: Martin 1994 and Martin 2001 minimum statistics.

Both are pure step functions ``(Pn, state) = step(S, state)`` on a run of periodogram
frames ``S`` (``(n_frames, n_bins)``, ``|X|^2``) with an explicit state, vectorized over
bins (algorithms.md section 6).  A batch call is the same step on all frames at once.

* :func:`ms1994_step` (Martin 1994): first-order smoothing
  ``P[l] = alpha P[l-1] + (1 - alpha) S[l]`` (``scipy.signal.lfilter`` over frames),
  the minimum of ``P`` over ``W`` sub-windows of ``M`` frames (running minimum of the
  current sub-window, a ring of the last ``W`` sub-window minima, immediate update when
  ``P`` falls below the current minimum), and bias compensation ``Pn = omin * Pmin`` with
  ``omin = 1 / E[Pmin]`` calibrated by Monte Carlo on unit white noise through the same
  filter bank (:func:`calibrate_omin`), never guessed.
* :func:`ms2001_step` (Martin 2001, optimal smoothing and bias compensation), following
  the structure and defaults of VOICEBOX ``estnoisem`` (taca .0449, tamax .392, taminh
  .0133, tpfall .064, tbmax .0717 s, qeqmin 2, qeqmax 14, av 2.12, td 1.536 s, nu 8).
  Its smoothing is recursive and nonlinear, so it loops over frames (vectorized over bins);
  runs of at most ``SMALL_RUN`` frames (streaming) take the same loop compiled
  (:func:`enhancers.kernels.stream.ms2001_frames`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import lfilter

from enhancers.core.filterbank import FilterBank
from scenesim.memo import array_key, cached_array
from scenesim.validate import check_int, check_positive, check_range

__all__ = [
    "MS1994State",
    "MS2001Config",
    "MS2001State",
    "calibrate_omin",
    "ms1994_init",
    "ms1994_step",
    "ms2001_init",
    "ms2001_step",
    "track_ms1994",
    "track_ms2001",
]

_TINY = 1e-300


# ---------------------------------------------------------------------------------------
# Martin 1994
# ---------------------------------------------------------------------------------------
@dataclass
class MS1994State:
    """State of :func:`ms1994_step`.

    Attributes
    ----------
    P : ndarray (n_bins,) or None
        Smoothed power of the previous frame (None before the first frame, which then
        initialises the smoother with its own periodogram).
    actmin : ndarray (n_bins,)
        Running minimum of the current (incomplete) sub-window (+inf when empty).
    ring : ndarray (W, n_bins)
        Minima of the last ``W`` completed sub-windows, oldest first (+inf initially).
    count : int
        Frames already in the current sub-window (0 .. M-1).
    """

    P: np.ndarray | None
    actmin: np.ndarray
    ring: np.ndarray
    count: int


#: Runs of at most this many frames go frame by frame (the streaming path; same arithmetic).
SMALL_RUN = 4


def ms1994_init(n_bins: int, *, n_sub: int) -> MS1994State:
    return MS1994State(P=None, actmin=np.full(n_bins, np.inf), ring=np.full((n_sub, n_bins), np.inf), count=0)


def ms1994_step(S: np.ndarray, state: MS1994State, *, alpha: float, sub_len: int) -> tuple[np.ndarray, np.ndarray, MS1994State]:
    """Smoothed power and its (uncompensated) windowed minimum for a run of frames.

    Parameters
    ----------
    S : ndarray, shape (F, K)
        Periodograms ``|X[l, k]|^2`` of ``F`` consecutive frames.
    state : MS1994State
    alpha : float
        Smoothing constant of ``P``.
    sub_len : int
        Sub-window length ``M`` in frames; the ring length ``W`` comes from the state.

    Returns
    -------
    P : ndarray (F, K)
        ``P[l] = alpha P[l-1] + (1 - alpha) S[l]``.
    Pmin : ndarray (F, K)
        ``min(min(ring), running min of the current sub-window)`` after frame ``l``
        (a minimum over the last ``W M`` to ``W M + M - 1`` frames).
    state : MS1994State (new object; the input state is not modified)
    """
    F, K = S.shape
    if F == 0:
        return np.zeros((0, K)), np.zeros((0, K)), state
    M, W = sub_len, state.ring.shape[0]
    if F == 1:
        return _ms1994_one_frame(S[0], state, alpha=alpha, sub_len=M)
    if F <= SMALL_RUN:  # streaming blocks longer than the hop: a few one-frame steps beat the scans
        out_p, out_min = np.empty((F, K)), np.empty((F, K))
        for i in range(F):
            out_p[i:i + 1], out_min[i:i + 1], state = _ms1994_one_frame(S[i], state, alpha=alpha, sub_len=M)
        return out_p, out_min, state
    p_prev = S[0] if state.P is None else state.P
    P = lfilter([1.0 - alpha], [1.0, -alpha], S, axis=0, zi=(alpha * p_prev)[None, :])[0]
    c = state.count
    total = c + F
    n_sub = -(-total // M)
    padded = np.full((n_sub * M, K), np.inf)
    padded[c:total] = P
    padded[:M] = np.minimum(padded[:M], state.actmin)  # the open sub-window continues
    running_all = np.minimum.accumulate(padded.reshape(n_sub, M, K), axis=1)
    running = running_all.reshape(n_sub * M, K)[c:total]
    n_done = total // M
    seq = np.concatenate([state.ring, running_all[:n_done, M - 1, :]], axis=0)
    ring_mins = sliding_window_view(seq, W, axis=0).min(axis=-1)  # (n_done + 1, K)
    g = np.arange(c, total)
    sub = g // M
    boundary = (g + 1) % M == 0
    Pmin = np.where(boundary[:, None], ring_mins[np.minimum(sub + 1, n_done)], np.minimum(ring_mins[sub], running))
    new = MS1994State(
        P=P[-1].copy(),
        actmin=np.full(K, np.inf) if total % M == 0 else running[-1].copy(),
        ring=seq[seq.shape[0] - W:].copy(),
        count=total % M,
    )
    return P, Pmin, new


def _ms1994_one_frame(s, state: MS1994State, *, alpha: float, sub_len: int):
    """Streaming fast path of :func:`ms1994_step` for one frame (same arithmetic, no scans)."""
    p_prev = s if state.P is None else state.P
    P = (1.0 - alpha) * s + alpha * p_prev
    actmin = np.minimum(state.actmin, P)
    count = state.count + 1
    if count == sub_len:
        ring = np.concatenate([state.ring[1:], actmin[None, :]], axis=0)
        Pmin = ring.min(axis=0)
        new = MS1994State(P=P, actmin=np.full(s.shape[0], np.inf), ring=ring, count=0)
    else:
        Pmin = np.minimum(state.ring.min(axis=0), actmin)
        new = MS1994State(P=P, actmin=actmin, ring=state.ring, count=count)
    return P[None, :], Pmin[None, :], new


#: Version of :func:`calibrate_omin`'s output.  Bump it whenever a change to the Monte
#: Carlo, the filter bank or :func:`ms1994_step` changes the values it returns: it is part of
#: the disk-cache key, so stale cached files then stop matching.
OMIN_VERSION = 1


@functools.lru_cache(maxsize=64)
def _calibrate_cached(alpha, n_sub, sub_len, frame_len, hop, window, n_frames, seed):
    key = array_key("ms1994-omin", OMIN_VERSION, alpha=alpha, n_sub=n_sub, sub_len=sub_len,
                    frame_len=frame_len, hop=hop, window=window, n_frames=n_frames, seed=seed)
    omin = cached_array(key, lambda: _calibrate(alpha, n_sub, sub_len, frame_len, hop, window, n_frames, seed))
    omin.setflags(write=False)
    return omin


def _calibrate(alpha, n_sub, sub_len, frame_len, hop, window, n_frames, seed) -> np.ndarray:
    fb = FilterBank(frame_len=frame_len, hop=hop, window=window)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((1, (n_frames + 1) * hop))
    X = fb.analyze(x)[0]
    # E|X_k|^2 of unit white noise is sum(w^2) in every bin
    S = np.abs(X) ** 2 / np.sum(fb.analysis_window**2)
    _, Pmin, _ = ms1994_step(S, ms1994_init(S.shape[1], n_sub=n_sub), alpha=alpha, sub_len=sub_len)
    settled = Pmin[(n_sub + 2) * sub_len:]
    mean = settled.mean(axis=0)
    omin = np.empty(S.shape[1])
    inner = mean[1:-1].mean() if S.shape[1] > 2 else mean.mean()
    omin[:] = 1.0 / inner
    # DC and Nyquist bins are real (chi-square with one degree of freedom): own factor
    omin[0] = 1.0 / mean[0]
    if frame_len % 2 == 0:
        omin[-1] = 1.0 / mean[-1]
    return omin


def calibrate_omin(
    *, alpha: float, n_sub: int, sub_len: int, frame_len: int = 256, hop: int = 128,
    window: str = "hamming", n_frames: int = 20000, seed: int = 1994,
) -> np.ndarray:
    """Bias compensation ``omin = 1 / E[Pmin]`` for unit-variance white noise, per bin (``(n_bins,)``).

    Monte Carlo: ``n_frames`` frames of seeded white noise through the same filter bank,
    smoother and minimum search; the expectation is the mean over time (after the first
    ``W + 2`` sub-windows) and over the interior bins (DC and Nyquist get their own
    value).  Cached per argument set (``functools.lru_cache`` in the process, and on disk
    through :func:`scenesim.memo.cached_array` when ``$SCENESIM_CACHE`` is set; the key
    holds every argument and :data:`OMIN_VERSION`); about 50-300 ms per computation.
    """
    return _calibrate_cached(float(alpha), int(n_sub), int(sub_len), int(frame_len), int(hop), str(window),
                             int(n_frames), int(seed))


def track_ms1994(S: np.ndarray, *, alpha: float, n_sub: int, sub_len: int, omin) -> np.ndarray:
    """Batch Martin 1994 noise PSD ``omin * Pmin`` of periodograms ``S`` (``(F, K)``) from a fresh state."""
    _, Pmin, _ = ms1994_step(S, ms1994_init(S.shape[1], n_sub=n_sub), alpha=alpha, sub_len=sub_len)
    return np.asarray(omin) * Pmin


# ---------------------------------------------------------------------------------------
# Martin 2001 (VOICEBOX estnoisem structure)
# ---------------------------------------------------------------------------------------
_MH_TABLE = np.array([
    [1, 0, 0], [2, 0.26, 0.15], [5, 0.48, 0.48], [8, 0.58, 0.78], [10, 0.61, 0.98],
    [15, 0.668, 1.55], [20, 0.705, 2], [30, 0.762, 2.3], [40, 0.8, 2.52], [60, 0.841, 3.1],
    [80, 0.865, 3.38], [120, 0.89, 4.15], [140, 0.9, 4.35], [160, 0.91, 4.25], [180, 0.92, 3.9],
    [220, 0.93, 4.1], [260, 0.935, 4.7], [300, 0.94, 5],
])  # M(D), H(D): Martin 2006 Table 5 as used by estnoisem


def _mh_values(d: int) -> tuple[float, float]:
    """``M(D)`` and ``H(D)`` interpolated in ``sqrt(D)`` (estnoisem ``mhvals``)."""
    tab = _MH_TABLE
    idx = np.nonzero(d <= tab[:, 0])[0]
    if idx.size == 0:
        i = j = tab.shape[0] - 1
    else:
        i = int(idx[0])
        j = i - 1
    if d == tab[i, 0]:
        return float(tab[i, 1]), float(tab[i, 2])
    qj, qi, q = math.sqrt(tab[i - 1, 0]), math.sqrt(tab[i, 0]), math.sqrt(d)
    h = tab[i, 2] + (q - qi) * (tab[j, 2] - tab[i, 2]) / (qj - qi)
    m = tab[i, 1] + (qi * qj / q - qj) * (tab[j, 1] - tab[i, 1]) / (qi - qj)
    return float(m), float(h)


def check_ms2001_fields(params) -> None:
    """Validate the Martin 2001 tracker constants an enhancer's ``Params`` carries.

    Time constants (``taca``, ``tamax``, ``taminh``, ``tpfall``, ``tbmax``, ``av``, ``td``)
    > 0, ``1 < qeqmin <= qeqmax``, integer ``nu >= 1``; raises ParameterError naming the field.
    """
    for name in ("taca", "tamax", "taminh", "tpfall", "tbmax", "av", "td"):
        check_positive(name, getattr(params, name))
    check_range("qeqmin", params.qeqmin, 1.0, math.inf, lo_open=True)
    check_range("qeqmax", params.qeqmax, params.qeqmin, math.inf)
    check_int("nu", params.nu, minimum=1)


@dataclass(frozen=True)
class MS2001Config:
    """Martin 2001 constants (seconds); defaults of VOICEBOX ``estnoisem``.  ``frame_step_s`` is the hop."""

    frame_step_s: float
    taca: float = 0.0449
    tamax: float = 0.392
    taminh: float = 0.0133
    tpfall: float = 0.064
    tbmax: float = 0.0717
    qeqmin: float = 2.0
    qeqmax: float = 14.0
    av: float = 2.12
    td: float = 1.536
    nu: int = 8
    qith: tuple = (0.03, 0.05, 0.06, math.inf)
    nsmdb: tuple = (47.0, 31.4, 15.7, 4.1)

    @functools.cached_property
    def derived(self) -> dict:
        tinc = self.frame_step_s
        nu = self.nu
        nv = round(self.td / (tinc * nu))
        if nv < 4:
            nv = 4
            nu = max(round(self.td / (tinc * nv)), 1)
        nd = nu * nv
        md, _ = _mh_values(nd)
        mv, _ = _mh_values(nv)
        return dict(
            aca=math.exp(-tinc / self.taca), amax=math.exp(-tinc / self.tamax),
            aminh=math.exp(-tinc / self.taminh), bmax=math.exp(-tinc / self.tbmax),
            snrexp=-tinc / self.tpfall, nv=nv, nu=nu, nd=nd, md=md, mv=mv,
            nsms=10.0 ** (np.asarray(self.nsmdb) * nv * tinc / 10.0),
            qeqimax=1.0 / self.qeqmin, qeqimin=1.0 / self.qeqmax,
        )


    @functools.cached_property
    def kernel_constants(self) -> np.ndarray:
        """The derived constants in the order :func:`enhancers.kernels.stream.ms2001_frames` reads them."""
        d = self.derived
        return np.array([d["aca"], d["amax"], d["aminh"], d["bmax"], d["snrexp"], d["nv"], d["nu"], d["nd"],
                         d["md"], d["mv"], self.av, d["qeqimax"], d["qeqimin"]], dtype=float)

    @functools.cached_property
    def kernel_qith(self) -> np.ndarray:
        return np.array(self.qith, dtype=float)


@dataclass
class MS2001State:
    """State of :func:`ms2001_step` (names follow ``estnoisem``); ``p is None`` before the first frame."""

    p: np.ndarray | None = None
    ac: float = 1.0
    sn2: np.ndarray | None = None
    pb: np.ndarray | None = None
    pb2: np.ndarray | None = None
    pminu: np.ndarray | None = None
    actmin: np.ndarray | None = None
    actminsub: np.ndarray | None = None
    subwc: int = 0
    actbuf: np.ndarray | None = None
    ibuf: int = 0
    lminflag: np.ndarray | None = None
    t: int = 0


def ms2001_init() -> MS2001State:
    return MS2001State()


def ms2001_step(S: np.ndarray, state: MS2001State, cfg: MS2001Config) -> tuple[np.ndarray, np.ndarray, MS2001State]:
    """Martin 2001 smoothed power ``P`` and noise PSD ``Pn`` (both ``(F, K)``) for periodogram frames ``S``.

    Equation numbers refer to Martin 2001 as annotated in ``estnoisem``: smoothing
    factor (9)-(12), smoothed power (3), variance estimate (20)-(23), bias (17),
    sub-window minimum search with local-minimum acceptance.  Every division is floored.
    """
    F, K = S.shape
    d = cfg.derived
    st = MS2001State(**{k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(state).items()})
    out = np.empty((F, K))
    pout = np.empty((F, K))
    if F == 0:
        return pout, out, st
    if st.p is None:
        p0 = S[0].copy()
        st.p, st.sn2, st.pb, st.pb2, st.pminu = p0, p0.copy(), p0.copy(), p0**2, p0.copy()
        st.actmin = np.full(K, np.inf)
        st.actminsub = np.full(K, np.inf)
        st.subwc = d["nv"]  # force a buffer switch on the first frame
        st.actbuf = np.full((d["nu"], K), np.inf)
        st.ibuf = 0
        st.lminflag = np.zeros(K, dtype=bool)
    if F <= SMALL_RUN:  # streaming: the compiled loop (enhancers.kernels.stream), unless switched off
        import enhancers.kernels.stream as sk  # lazy: numba's import is only paid when streaming

        if sk.MAX_BLOCK > 0:
            return _ms2001_compiled(sk, S, st, cfg)
    aca, amax, aminh, bmax = d["aca"], d["amax"], d["aminh"], d["bmax"]
    nv, nu, nd, md, mv = d["nv"], d["nu"], d["nd"], d["md"], d["mv"]
    p, ac, sn2, pb, pb2 = st.p, st.ac, st.sn2, st.pb, st.pb2
    for f in range(F):
        yft = S[f]
        st.t += 1
        sum_y = max(yft.sum(), _TINY)
        sum_sn2 = max(sn2.sum(), _TINY)
        ratio = min(p.sum() / sum_y, 1e100)  # bounded: a silent frame must not overflow
        acb = 1.0 / (1.0 + (ratio - 1.0) ** 2)                               # (9)
        ac = aca * ac + (1.0 - aca) * max(acb, aca)                           # (10)
        ah = amax * ac / (1.0 + (p / np.maximum(sn2, _TINY) - 1.0) ** 2)      # (11)
        snr = max(p.sum() / sum_sn2, _TINY)
        ah = np.maximum(ah, min(aminh, snr ** d["snrexp"]))                   # (12)
        p = ah * p + (1.0 - ah) * yft                                         # (3)
        b = np.minimum(ah**2, bmax)
        pb = b * pb + (1.0 - b) * p                                           # (20)
        pb2 = b * pb2 + (1.0 - b) * p**2                                      # (21)
        qeqi = np.maximum(np.minimum((pb2 - pb**2) / np.maximum(2.0 * sn2**2, _TINY), d["qeqimax"]),
                          d["qeqimin"] / st.t)                                # (23)
        qiav = qeqi.sum() / K
        bc = 1.0 + cfg.av * math.sqrt(qiav)
        bmind = 1.0 + 2.0 * (nd - 1) * (1.0 - md) / (1.0 / qeqi - 2.0 * md)  # (17)
        bminv = 1.0 + 2.0 * (nv - 1) * (1.0 - mv) / (1.0 / qeqi - 2.0 * mv)
        cand = bc * p * bmind
        kmod = cand < st.actmin
        st.actmin = np.where(kmod, cand, st.actmin)
        st.actminsub = np.where(kmod, bc * p * bminv, st.actminsub)
        if 1 < st.subwc < nv:  # middle of a sub-window: allow a local minimum
            st.lminflag |= kmod
            st.pminu = np.minimum(st.actminsub, st.pminu)
            sn2 = st.pminu
        elif st.subwc >= nv:  # end of a sub-window: buffer switch
            st.ibuf = st.ibuf % nu + 1
            st.actbuf[st.ibuf - 1] = st.actmin
            st.pminu = st.actbuf.min(axis=0)
            nsm = d["nsms"][int(np.nonzero(qiav < np.asarray(cfg.qith))[0][0])]
            lmin = st.lminflag & ~kmod & (st.actminsub < nsm * st.pminu) & (st.actminsub > st.pminu)
            if lmin.any():
                st.pminu = np.where(lmin, st.actminsub, st.pminu)
                st.actbuf[:, lmin] = st.pminu[lmin]
            st.lminflag[:] = False
            st.actmin = np.full(K, np.inf)
            st.subwc = 0
        st.subwc += 1
        out[f] = sn2
        pout[f] = p
    st.p, st.ac, st.sn2, st.pb, st.pb2 = p, ac, sn2, pb, pb2
    return pout, out, st


def _ms2001_compiled(sk, S: np.ndarray, st: MS2001State, cfg: MS2001Config):
    """:func:`ms2001_step`'s frame loop as :func:`enhancers.kernels.stream.ms2001_frames`; ``st`` (a copy) updated."""
    sc = np.array([st.ac, st.subwc, st.ibuf, st.t], dtype=float)
    P, Pn = sk.ms2001_frames(np.ascontiguousarray(S), st.p, st.sn2, st.pb, st.pb2, st.pminu, st.actmin,
                             st.actminsub, st.actbuf, st.lminflag, sc, cfg.kernel_constants, cfg.kernel_qith,
                             cfg.derived["nsms"])
    ac, subwc, ibuf, t = sc.tolist()
    st.ac, st.subwc, st.ibuf, st.t = ac, int(subwc), int(ibuf), int(t)
    return P, Pn, st


def track_ms2001(S: np.ndarray, *, frame_step_s: float, **constants) -> np.ndarray:
    """Batch Martin 2001 noise PSD of periodograms ``S`` (``(F, K)``) from a fresh state."""
    _, out, _ = ms2001_step(S, ms2001_init(), MS2001Config(frame_step_s=frame_step_s, **constants))
    return out


def warm_up() -> None:
    """Compile (or load from numba's cache) the streaming kernels, Martin 2001's frame loop included.

    :func:`enhancers.kernels.stream.warm_up` compiles the kernels that need no tracker state; the
    Martin 2001 loop is compiled here, through the step that owns its state.

    >>> warm_up()
    """
    import enhancers.kernels.stream as sk  # lazy: numba's import is only paid when asked for

    sk.warm_up()
    x = np.random.default_rng(0).standard_normal((2, 40))
    ms2001_step(np.abs(np.fft.rfft(x, axis=-1)) ** 2, ms2001_init(), MS2001Config(frame_step_s=0.008))
