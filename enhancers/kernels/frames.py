"""Compiled frame step of ``mic-calibration``, ``eb-subband`` and ``eb-robust`` (issue 20: streaming speed).

Streaming in 10 ms blocks hands the enhancers one or two STFT frames per call; the numpy step of
:mod:`enhancers.beam.mic_calibration` and :mod:`enhancers.beam.subband_eb` then spends ~2 ms per block in ~150
small numpy calls.  This module packs the parameters, per-bin constants and state into arrays once per
stream and runs the frames through one numba kernel (:func:`enhancers.kernels.robust.run_frames`).
Batch processing runs the same kernel on all frames, so batch equals streaming exactly.

The numpy implementations stay the reference (``tests/test_fast_frames.py`` compares the two to
rounding).  The kernel covers the default algorithm: the calibration's cardioid rules without the frame
rule, the rear rule or the start-up ramp (``frame_q_db=None``, ``cal_rear_db=None``, ``ramp_frames=0``), the
per-bin estimate (``model="bins"``), and the per-bin NLMS beamformer with its gate, EQ and DAS mix; other
parameter sets, or ``COMPILED = False``, run the reference.

Measured (``python -m benchmarks.perf.enhancer_rtf --only mic-calibration eb-robust eb-subband
eb-robust-ss --runs 3``, CPU real-time factors, load 9 on 2 cores): streaming in 10 ms blocks
mic-calibration 0.111 -> 0.008, eb-robust 0.21 -> 0.008, eb-subband 0.032 -> 0.004, eb-robust-ss
0.25 -> 0.042 (its ``ss`` stage is most of the rest); streaming / batch 12.6 / 15.2 / 8.0 / 15.5 ->
1.5 / 1.5 / 1.8 / 5.6.  First call in a fresh install: the kernels compile once (~30 s CPU,
``cache=True`` keeps them under ``__pycache__``; set ``NUMBA_CACHE_DIR`` for a read-only install);
with the cache, a new process loads them in ~0.8 s CPU.

The state (:class:`FastState`) is updated in place (``Enhancer.process_block``'s contract allows it):
always pass on the state a call returns, never reuse an old one.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from enhancers.core.eq import look_eq_gain
from enhancers.core.stft_stage import bin_omega

__all__ = ["COMPILED", "FastState", "FusedStreaming", "kernel_supports", "new_state", "wola_back", "wola_from",
           "wola_maker", "wola_state"]

#: False: new streams (and batch runs) use the numpy reference instead of the compiled kernel.
COMPILED = True


#: Fields the kernel implements for any value (the filter bank's, the calibration's default mode, the beamformer's).
KERNEL_FIELDS = frozenset((
    "spacing_m", "c_mps", "frame_len", "hop", "window",
    "tau_s", "fit_band_hz", "smooth_bins", "smooth_frac", "estimate_every", "max_gain_db", "max_phase_deg",
    "min_coherence", "phase_leak", "freeze_db", "freeze_band_db", "gate_lam_cal", "floor_s",
    "mu", "lam", "eps", "beta0", "adapt_gate_db", "gate_lam", "gate_floor_s", "eq", "eq_max_gain_db",
    "eq_noise_gain_db", "eq_highpass_hz", "eq_phase", "das_mix", "mix_lam", "mix_smooth_bins", "mix_alpha0",
    "calibrate"))
#: The frame rule's hold and floor: no effect while ``frame_q_db`` is None.
_OFF_WITH_THE_MODE = frozenset(("level_floor_s", "level_hang_s", "level_ahead_s"))


def kernel_supports(p) -> bool:
    """Whether the kernel covers params ``p``: no start-up ramp, and every field it does not know (the frame
    and rear rules, the sensor model, the pooled and delayed estimates) at its default.

    >>> import enhancers
    >>> kernel_supports(enhancers.make("eb-robust").params)
    True
    >>> kernel_supports(enhancers.make("eb-robust", frame_q_db=5.0).params)
    False
    """
    if float(getattr(p, "ramp_frames", 0.0)) != 0.0:
        return False
    known = KERNEL_FIELDS | _OFF_WITH_THE_MODE | {"ramp_frames"}
    return all(getattr(p, f.name) == f.default for f in dataclasses.fields(p) if f.name not in known)


class FastState:
    """One stream's arrays (see :mod:`enhancers.kernels.robust` for the rows), updated in place.

    ``wola``: the fused streaming step's filter-bank arrays (None where the frame length is not a
    power of two: blocks then go through :class:`enhancers.core.filterbank.FilterBank` and :meth:`frames`).
    """

    __slots__ = ("args", "calibrate", "beam", "das_mix", "wola")

    def __init__(self, args: tuple, *, calibrate: bool, beam: bool, das_mix: bool, wola: tuple | None = None):
        self.args, self.calibrate, self.beam, self.das_mix, self.wola = args, calibrate, beam, das_mix, wola

    def block(self, block: np.ndarray) -> np.ndarray:
        """One streaming block ``(2, b)`` -> output samples ``(C, b)`` (analysis, frames, synthesis fused)."""
        from enhancers.kernels.robust import run_block  # lazy: numba

        return run_block(np.ascontiguousarray(block, dtype=float), *self.wola, *self.args)

    def frames(self, X: np.ndarray):
        """Frames ``X (2, F, K)`` -> ``(Y (2, F, K) or (F, K), record)``: the calibrated pair (calibration
        only) or the beamformer output, and the record of the reference step (``r_hat``, ``frozen``,
        ``beta``, ``eq``, ``alpha``, as applicable)."""
        from enhancers.kernels.robust import run_frames  # lazy: numba's import costs ~0.3 s

        _, F, K = X.shape
        X = np.ascontiguousarray(X, dtype=complex)
        out = np.empty((4, F, K), dtype=complex)  # (front, output, r_hat, G)
        reals = np.empty((2, F, K))  # (beta, alpha)
        frozen = np.zeros((F, K), dtype=bool)
        run_frames(X[0], X[1], *self.args, out[1:], reals, frozen)
        record = {}
        if self.calibrate:
            record.update(r_hat=out[2], frozen=frozen)
        if not self.beam:
            out[0] = X[0]
            return out[:2], record
        record.update(beta=reals[0], eq=out[3])
        if self.das_mix and F:
            record["alpha"] = reals[1]
        return out[1], record


def _calibration_constants(p, fs: int, delay: float, band: slice, K: int):
    """``(par, ipar)`` entries and the band-smoothing bounds ``(2, K)`` of the calibration."""
    n_window = int(math.ceil(float(p.floor_s) * fs / int(p.hop))) if p.floor_s > 0 else 0
    k = np.arange(K)
    half = np.maximum(int(p.smooth_bins), np.round(float(p.smooth_frac) * k).astype(int))
    bounds = np.stack([np.maximum(k - half, 0), np.minimum(k + half + 1, K)]).astype(np.int64)
    par = {"P_GL": float(p.gate_lam_cal),
           "P_THR_BIN": 10.0 ** (float(p.freeze_db) / 10.0), "P_THR_BAND": 10.0 ** (float(p.freeze_band_db) / 10.0),
           "P_CMIN": 1.0 - math.exp(-int(p.hop) / (fs * float(p.tau_s))),
           "P_MAXSLOPE": 2 * math.pi * delay / int(p.frame_len), "P_MAXGAIN": float(p.max_gain_db),
           "P_MAXPHASE": math.radians(float(p.max_phase_deg)), "P_MINCOH": float(p.min_coherence),
           "P_LEAK": float(p.phase_leak)}
    ipar = {"I_CAL": 1, "I_LO": band.start, "I_HI": band.stop, "I_NWC": n_window, "I_EVERY": int(p.estimate_every)}
    return par, ipar, bounds, n_window


def _beam_constants(p, fs: int, gate_window: int):
    """``(par, ipar)`` entries of the sub-band beamformer (NLMS, gate, EQ, DAS mix)."""
    gate = p.adapt_gate_db is not None
    par = {"P_MU": float(p.mu), "P_LAM": float(p.lam), "P_EPS": float(p.eps),
           "P_GLAM": float(p.lam if p.gate_lam is None else p.gate_lam),
           "P_THR_GATE": 10.0 ** (float(p.adapt_gate_db) / 10.0) if gate else 0.0, "P_MIXLAM": float(p.mix_lam),
           "P_ALPHA0": float(p.mix_alpha0),
           "P_BOUND": 10.0 ** (float(p.eq_noise_gain_db) / 10.0) if p.eq_noise_gain_db is not None else 0.0}
    ipar = {"I_BEAM": 1, "I_GATE": int(gate), "I_NWG": gate_window if gate else 0, "I_MIX": int(bool(p.das_mix)),
            "I_MIXH": int(p.mix_smooth_bins), "I_EQ": int(bool(p.eq)), "I_NOISE": int(p.eq_noise_gain_db is not None),
            "I_PHASE": int(bool(p.eq_phase)), "I_HP": int(float(p.eq_highpass_hz) > 0)}
    return par, ipar


def _bin_constants(p, fs: int, delay: float, K: int, band: slice | None) -> np.ndarray:
    """Per-bin constants ``(N_CST, K)``: the rows named in :mod:`enhancers.kernels.robust`."""
    from enhancers.kernels import robust as kr

    n = int(p.frame_len)
    omega = bin_omega(n)
    wt = omega * delay
    ph = np.exp(-1j * omega * delay)  # the cardioids' and the DAS path's e^{-j w T}, as the reference forms it
    cst = np.ones((kr.N_CST, K))
    cst[kr.K_PHR], cst[kr.K_PHI] = ph.real, ph.imag
    if getattr(p, "eq", False):
        cst[kr.K_GSTATIC] = look_eq_gain(np.zeros(K), omega=omega, delay_samples=delay, freqs_hz=omega / (2 * np.pi) * fs,
                                         max_gain_db=float(p.eq_max_gain_db))
        if float(p.eq_highpass_hz) > 0:  # enhancers.core.eq's Butterworth magnitude (the reference multiplies by it last)
            r = (np.asarray(omega / (2 * np.pi) * fs, dtype=float) / float(p.eq_highpass_hz)) ** 2
            cst[kr.K_HPF] = r / np.sqrt(1.0 + r * r)
    cst[kr.K_COSWT] = np.cos(wt)
    cst[kr.K_LOOK2] = np.abs(2.0 * np.sin(wt))
    cst[kr.K_INBAND] = 0.0
    if band is not None:
        cst[kr.K_INBAND, band] = 1.0
    return cst


def wola_state(filterbank, n_out: int, n_in: int = 2) -> tuple | None:
    """A fresh stream's filter-bank arrays of a fused streaming step (``_kernels_robust.run_block``,
    ``stream_kernels.ss_block``): ``(tail (n_in, N - 1), ola (n_out, N - R), queue (n_out, R), wst, windows
    (2, N), FFT tables)``; None unless ``N = 2^k`` and ``R`` divides ``N``.

    >>> from enhancers.core.filterbank import FilterBank
    >>> [a.shape for a in wola_state(FilterBank(frame_len=8, hop=4), 1, n_in=1)[:3]]
    [(1, 7), (1, 4), (1, 4)]
    >>> wola_state(FilterBank(frame_len=12, hop=4), 1) is None
    True
    """
    from enhancers.kernels.wola import fft_tables

    n, r = filterbank.frame_len, filterbank.hop
    if n & (n - 1) or n % r:
        return None
    rev, tw = fft_tables(n)
    win = np.stack([filterbank.analysis_window, filterbank.synthesis_window])
    return (np.zeros((n_in, n - 1)), np.zeros((n_out, n - r)), np.zeros((n_out, r)),
            np.array([0, r - 1, r], dtype=np.int64), win, rev, tw)


def wola_maker(filterbank, n_out: int, n_in: int = 2):
    """A callable returning fresh :func:`wola_state` arrays, or None when the fused step does not apply.

    >>> from enhancers.core.filterbank import FilterBank
    >>> wola_maker(FilterBank(frame_len=12, hop=4), 1) is None
    True
    """
    if wola_state(filterbank, n_out, n_in) is None:
        return None
    return functools.partial(wola_state, filterbank, n_out, n_in)


def wola_from(wola: tuple, analysis, synthesis) -> tuple:
    """``wola`` (:func:`wola_state`'s arrays) filled with a stream's filter-bank state: ``analysis``'s
    ``tail`` and ``phase``, ``synthesis``' ``ola`` and ``queue`` (:class:`enhancers.core.filterbank.FilterBankState`)."""
    tail, ola, queue, wst = wola[:4]
    tail[:], ola[:] = analysis.tail, synthesis.ola
    ql = synthesis.queue.shape[1]  # always R - 1 - phase < R
    queue[:, :ql] = synthesis.queue
    wst[0], wst[1] = analysis.phase, ql
    return wola


def wola_back(wola: tuple):
    """The :class:`enhancers.core.filterbank.FilterBankState` held by ``wola``'s arrays (copies; the inverse of
    :func:`wola_from`): its ``tail``/``phase`` serve an analysis step, its ``ola``/``queue`` a synthesis step."""
    from enhancers.core.filterbank import FilterBankState

    tail, ola, queue, wst = wola[:4]
    return FilterBankState(tail=tail.copy(), phase=int(wst[0]), ola=ola.copy(), queue=queue[:, :wst[1]].copy())


def new_state(p, fs: int, n_bins: int, *, delay: float, filterbank, band: slice | None = None,
              gate_window: int = 0, beam: bool = True) -> FastState:
    """A fresh stream's state for params ``p``: the calibration when ``band`` (its ``fit_band_hz`` bins)
    is given, then the sub-band beamformer when ``beam`` (``gate_window``: its gate's floor in frames);
    ``filterbank`` (:class:`enhancers.core.filterbank.FilterBank`): the fused streaming step's."""
    from enhancers.kernels import robust as kr

    K = n_bins
    par_d, ipar_d, bounds, nwc = {}, {"I_CAL": 0, "I_BEAM": 0}, np.zeros((2, K), dtype=np.int64), 0
    if band is not None:
        cp, ci, bounds, nwc = _calibration_constants(p, fs, delay, band, K)
        par_d.update(cp)
        ipar_d.update(ci)
    if beam:
        bp, bi = _beam_constants(p, fs, gate_window)
        par_d.update(bp)
        ipar_d.update(bi)
    par = np.zeros(kr.N_PAR)
    for name, value in par_d.items():
        par[getattr(kr, name)] = value
    ipar = np.zeros(kr.N_IPAR, dtype=np.int64)
    for name, value in ipar_d.items():
        ipar[getattr(kr, name)] = value
    rs = np.zeros((kr.N_RS, K))
    beta0 = float(getattr(p, "beta0", 0.0))
    rs[kr.R_BETA] = beta0
    cs = np.zeros((kr.N_CS, K), dtype=complex)
    cs[kr.C_RLAST] = cs[kr.C_RAWLAST] = 1.0
    depth = max(nwc, int(ipar[kr.I_NWG]), 1)
    args = (par, ipar, _bin_constants(p, fs, delay, K, band), bounds, rs, cs, np.zeros((3, K, depth)),
            np.zeros((3, K, depth), dtype=np.int64), np.zeros((3, 2, K), dtype=np.int64))
    return FastState(args, calibrate=band is not None, beam=beam, das_mix=bool(getattr(p, "das_mix", False)),
                     wola=wola_state(filterbank, 1 if beam else 2))


class FusedStreaming:
    """Mixin of the STFT enhancers with a compiled step: ``process_block`` runs the fused kernel
    (filter bank included) when the stream's state is a :class:`FastState` with ``wola`` arrays."""

    def _process_block(self, block, state):
        algo = state.algo
        if isinstance(algo, FastState) and algo.wola is not None:
            return algo.block(block), state
        return super()._process_block(block, state)
