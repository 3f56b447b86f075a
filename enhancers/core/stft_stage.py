"""Shared machinery of the STFT-domain two-mic enhancers (sub-band EB, mic calibration, robust EB).

Every such enhancer analyses its input with the WOLA filter bank of
:mod:`enhancers.core.filterbank` (16 ms Hamming, 50 % overlap at 16 kHz by default), processes
the complete frames with a pure step ``(Y, state, record) = frames(X, state)`` and
resynthesises.  ``record`` holds the per-frame quantities the step adapted (beta per bin,
rear-mic correction per bin, EQ gain per bin): with them fixed, the operation is linear,
so ``Result.replay`` analyses a component, applies the same record and resynthesises
(exact shadow filtering, algorithms.md section 8).  Batch processing runs the very step
used for streaming on the whole signal, so batch equals streaming for every block size.

Latency: ``frame_len - 1`` samples (the filter bank's).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from scipy.ndimage import minimum_filter1d
from scipy.signal import lfilter

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from enhancers.core.filterbank import FilterBank, FilterBankState
from scenesim.errors import ParameterError
from scenesim.validate import check_int, check_positive

__all__ = ["GateState", "StftEnhancer", "StftParams", "bin_omega", "gate_init", "power_ratio_gate", "ratio_gate",
           "smooth_frames"]

TINY = 1e-300


@dataclass(frozen=True)
class StftParams(Params):
    """Geometry and filter-bank fields shared by the STFT-domain two-mic enhancers."""

    spacing_m: float = 0.0214
    c_mps: float = 343.0
    frame_len: int = 256
    hop: int = 128
    window: str = "hamming"

    def _check_stft(self):
        check_positive("spacing_m", self.spacing_m)
        check_positive("c_mps", self.c_mps)
        n = check_int("frame_len", self.frame_len, minimum=16, maximum=8192)
        check_int("hop", self.hop, minimum=1, maximum=n)
        if n % self.hop:
            raise ParameterError("hop", self.hop, f"a divisor of frame_len={n}")
        _filterbank(self.frame_len, self.hop, self.window)  # validates the window name and overlap


@functools.lru_cache(maxsize=32)
def _filterbank(frame_len: int, hop: int, window: str) -> FilterBank:
    return FilterBank(frame_len=frame_len, hop=hop, window=window)


def bin_omega(frame_len: int) -> np.ndarray:
    """Normalised angular frequency of each rfft bin, ``2 pi k / N`` (rad/sample), ``(N/2 + 1,)``."""
    return 2.0 * np.pi * np.arange(frame_len // 2 + 1) / frame_len


def smooth_frames(x: np.ndarray, lam: float, prev: np.ndarray) -> np.ndarray:
    """One-pole average over frames (axis 0): ``P[l] = lam P[l-1] + (1 - lam) x[l]``, ``P[-1] = prev``.

    ``x`` is ``(F, ...)``, ``prev`` the last value of the previous call (``x.shape[1:]``).
    Returns ``P`` with ``x``'s shape (``F = 0`` gives an empty array).
    """
    if x.shape[0] == 0:
        return x.copy()
    if x.shape[0] <= 2:  # streaming at the hop: the recursion itself, lfilter's arithmetic without its overhead
        out = np.empty(x.shape, dtype=np.result_type(x, prev, float))
        y = np.asarray(prev)
        for i in range(x.shape[0]):
            y = (1.0 - lam) * x[i] + lam * y
            out[i] = y
        return out
    zi = (lam * np.asarray(prev))[None]
    y, _ = lfilter([1.0 - lam], [1.0, -lam], x, axis=0, zi=zi)
    return y


def _running_min(full: np.ndarray, n: int) -> np.ndarray:
    """``out[i] = min(full[i : i + n])`` along axis 0 for the last ``len(full) - n + 1`` positions.

    A few frames (streaming) take the minimum directly; long inputs use scipy's running
    minimum (its centred window shifted to be causal by ``origin``).
    """
    n_out = full.shape[0] - n + 1
    if n_out <= 4:
        return np.stack([full[i:i + n].min(axis=0) for i in range(n_out)])
    floor = minimum_filter1d(full, n, axis=0, origin=(n - 1) // 2, mode="constant", cval=np.inf)
    return floor[n - 1:]


@dataclass(frozen=True)
class GateState:
    """State of :func:`power_ratio_gate`: last smoothed powers ``(K,)`` and the floor's history."""

    pf: np.ndarray
    pb: np.ndarray
    sf: np.ndarray | None = None  # the floor's (slower) smoothed powers, when floor_lam is set
    sb: np.ndarray | None = None
    hist: np.ndarray | None = None  # (n_window - 1, K) last floor ratios P_F / P_B (linear)


def gate_init(n_bins: int) -> GateState:
    z = np.zeros(n_bins)
    return GateState(pf=z, pb=z, sf=z, sb=z)


def ratio_gate(cF, cB, **kwargs):
    """:func:`power_ratio_gate` of the powers ``|cF|^2``, ``|cB|^2`` of two complex ``(F, K)`` arrays."""
    return power_ratio_gate(cF.real**2 + cF.imag**2, cB.real**2 + cB.imag**2, **kwargs)


def power_ratio_gate(eF, eB, *, state: GateState, gate_db: float, lam: float, n_window: int,
                     floor_lam: float | None = None, cap: float = 1.0):
    """Per-bin "frontal source dominates" detector (the rule of ``eb-gated``, per bin).

    ``r = 10 log10(P_F / P_B)`` of the one-pole smoothed (``lam`` per frame) powers ``eF``,
    ``eB`` ``(F, K)`` of the forward/backward cardioids; True where
    ``r > min(floor, 0) + gate_db``, ``floor`` = running minimum over the last ``n_window``
    frames (0: no floor, reference 0 dB) of the same ratio, or, with ``floor_lam``, of the
    ratio of powers smoothed more slowly (``floor_lam`` per frame): the minimum of a
    fluctuating ratio sits below its mean, so a fast detector compared with the minimum of
    its own fluctuations freezes stationary noise most of the time.  A rear source gives
    ``r < 0``, a diffuse field ~0 dB, a frontal talker ``r > 0``.  (``cap``: the reference
    is ``min(floor, cap)``.)

    Returns ``(frozen (F, K) bool, new GateState)``.
    """
    pf = smooth_frames(eF, lam, state.pf)
    pb = smooth_frames(eB, lam, state.pb)
    # compared in the linear domain (monotone, so the running minimum is the same): no log per bin
    r = (pf + TINY) / (pb + TINY)  # silence: ratio 1 (0 dB), never NaN
    sf = sb = None
    if floor_lam is None:
        rf = r
    else:
        sf = smooth_frames(eF, floor_lam, state.sf)
        sb = smooth_frames(eB, floor_lam, state.sb)
        rf = (sf + TINY) / (sb + TINY)
        sf, sb = sf[-1].copy(), sb[-1].copy()
    hist = state.hist
    if n_window > 1:
        if hist is None:
            hist = np.full((n_window - 1, r.shape[1]), np.inf)
        if rf.shape[0] == 1:  # streaming at the hop: the window's minimum directly, one copy of the history
            ref = np.minimum(np.minimum(hist.min(axis=0), rf[0]), cap)[None]
            hist = np.concatenate([hist[1:], rf], axis=0)
        else:
            full = np.concatenate([hist, rf], axis=0)
            ref = np.minimum(_running_min(full, n_window), cap)
            hist = full[full.shape[0] - (n_window - 1):].copy()
    elif n_window == 1:
        ref = np.minimum(rf, cap)
    else:
        ref = np.full_like(r, min(cap, 1.0))
    return r > ref * 10.0 ** (gate_db / 10.0), GateState(pf=pf[-1].copy(), pb=pb[-1].copy(), sf=sf, sb=sb, hist=hist)


@dataclass
class StftState:
    """Streaming state: the filter bank's and the algorithm's (replaced, never mutated)."""

    fb: FilterBankState
    algo: Any
    fs: int


class StftEnhancer(Enhancer):
    """Base of the STFT-domain two-mic enhancers; subclasses implement the frame step.

    Subclass hooks
    --------------
    ``_algo_init(fs, n_bins)`` -> algorithm state.
    ``_frames(X, algo, fs)`` with ``X`` ``(channels_in, F, K)`` -> ``(Y (channels_out, F, K), algo, record)``;
    ``record`` is a dict of arrays whose first axis is the frame.
    ``_apply(record, X, fs)`` -> ``Y``: the same linear operation for a component's frames.
    ``_trace(record)`` -> the ``Result.trace`` dict.
    """

    channels_out: ClassVar[int] = 1
    Params: ClassVar[type[Params]] = StftParams

    @functools.cached_property
    def filterbank(self) -> FilterBank:  # params are frozen (cached: read per block)
        p = self.params
        return _filterbank(int(p.frame_len), int(p.hop), p.window)

    @property
    def hop(self) -> int:
        """Frame hop in samples (the conformance suite streams in blocks of it)."""
        return int(self.params.hop)

    def delay_samples(self, fs: int) -> float:
        """Inter-mic travel time ``T fs = spacing_m fs / c_mps`` in samples."""
        return float(self.params.spacing_m) / float(self.params.c_mps) * fs

    @functools.cached_property
    def tags(self) -> Tags:  # params are frozen, so the tags never change (cached: read per block)
        return Tags(channels_in=2, channels_out=self.channels_out, needs_geometry=True, streaming=True,
                    latency_samples=int(self.params.frame_len) - 1)

    # -- hooks ---------------------------------------------------------------------------
    def _algo_init(self, fs: int, n_bins: int):  # pragma: no cover
        raise NotImplementedError

    def _frames(self, X: np.ndarray, algo, fs: int):  # pragma: no cover
        raise NotImplementedError

    def _apply(self, record: dict, X: np.ndarray, fs: int) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _trace(self, record: dict) -> dict:
        return {}

    # -- streaming and batch ------------------------------------------------------------------
    def _init_state(self, fs: int) -> StftState:
        fb = self.filterbank
        # analysis fields (tail, phase) for the 2 inputs, synthesis fields (ola, queue) for the outputs
        ana, syn = fb.init_state(2), fb.init_state(self.channels_out)
        fbs = FilterBankState(tail=ana.tail, phase=ana.phase, ola=syn.ola, queue=syn.queue)
        return StftState(fb=fbs, algo=self._algo_init(fs, fb.n_bins), fs=fs)

    def _step(self, block: np.ndarray, state: StftState):
        fb = self.filterbank
        X, fbs = fb.analysis_step(block, state.fb)
        Y, algo, record = self._frames(X, state.algo, state.fs)
        out, fbs = fb.synthesis_step(Y, block.shape[-1], fbs)
        return out, StftState(fb=fbs, algo=algo, fs=state.fs), record

    def _process_block(self, block, state):
        out, new, _ = self._step(block, state)
        return out, new

    def _process(self, x: np.ndarray, fs: int) -> Result:
        out, _, record = self._step(x, self._init_state(fs))
        fb = self.filterbank
        n = x.shape[-1]
        for value in record.values():
            value.setflags(write=False)

        def replay(component) -> np.ndarray:
            comp = check_component(component, (2, n))
            return fb.synthesize(self._apply(record, fb.analyze(comp), fs), n)

        return Result(output=out, trace=self._trace(record), _replay=replay)
