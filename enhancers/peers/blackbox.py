"""Frame-buffered wrapper for black-box peers (external libraries that process fixed frames).

A library such as WebRTC's noise suppressor or RNNoise takes exactly ``F`` samples per
call (10 ms) and keeps its own opaque state.  :class:`FramedBlackBox` turns it into a
streaming enhancer with the project's time alignment (:mod:`enhancers.core.base`): input is
buffered until a frame is complete, the frame goes through the library, and the output
queue starts with ``F - 1`` zeros, so ``output[n]`` depends on input up to ``n`` and
is the library's output delayed by ``F - 1`` samples (plus the library's own delay,
declared by the subclass).  Batch processing is the same step on the whole signal, so
batch and streaming outputs are identical.  Samples of a last, incomplete frame are
never sent to the library; the output keeps the input's length.

Black boxes cannot replay their operation on a component (``tags.replayable`` False):
the benchmark measures them by phase inversion (``benchmarks.metrics.evaluate``: outputs for
``s + n`` and ``s - n``).  They need no declared conformance expected failures: the
replay checks apply only to replayable enhancers, and every other check (streaming ==
batch, state isolation, determinism, silence, pickling of the enhancer) holds because the
library state lives in the stream state, one per stream.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np
from scipy.signal import firwin

from enhancers.core.base import Enhancer, Result, Tags

__all__ = ["FramedBlackBox", "Resampler16to48", "to_int16_scale"]

INT16_SCALE = 32768.0
"""Full scale (|x| = 1) in the int16 units the libraries take."""


def to_int16_scale(x: np.ndarray) -> np.ndarray:
    """Full-scale float samples to int16 units, clipped to the int16 range (float64 result)."""
    return np.clip(np.asarray(x, dtype=float) * INT16_SCALE, -INT16_SCALE, INT16_SCALE - 1.0)


_UP = 3
_RATE_LIB = 48000
_N_TAPS = 97  # (97 - 1) / 2 = 48 samples of delay per filter at 48 kHz: a whole 16 kHz sample count
_HIST_UP = (_N_TAPS - 1) // _UP  # 16 kHz input samples the up filter looks back (32)
_HIST_DOWN = _N_TAPS - 1  # 48 kHz input samples the down filter looks back (96)


@functools.lru_cache(maxsize=1)
def _lowpass() -> np.ndarray:
    return firwin(_N_TAPS, 7600.0, window=("kaiser", 8.0), fs=_RATE_LIB)


@functools.lru_cache(maxsize=1)
def _up_phases() -> np.ndarray:
    """``(3, 33)``: row ``p`` holds the taps ``3 h[p + 3j]`` that output phase ``p`` applies (0-padded)."""
    h = np.zeros(_UP * (_HIST_UP + 1))
    h[:_N_TAPS] = _UP * _lowpass()
    return np.ascontiguousarray(h.reshape(-1, _UP).T)


@numba.njit(cache=True, nogil=True)
def _up_kernel(x, hist, phases, out, gain, lo, hi):  # pragma: no cover - compiled; tested through Resampler16to48
    """``out[3m + p] = clip(gain * sum_j phases[p, j] x[m - j], lo, hi)``, ``x[<0]`` from ``hist``; updates ``hist``."""
    k, n_hist = x.size, hist.size
    for m in range(k):
        for p in range(phases.shape[0]):
            acc = 0.0
            for j in range(phases.shape[1]):
                acc += phases[p, j] * (x[m - j] if m >= j else hist[n_hist + m - j])
            out[_UP * m + p] = min(max(gain * acc, lo), hi)
    _push(hist, x)


@numba.njit(cache=True, nogil=True)
def _down_kernel(y, hist, h, out, gain):  # pragma: no cover - compiled; tested through Resampler16to48
    """``out[m] = gain * sum_t h[t] y[3m - t]``, ``y[<0]`` from ``hist``; updates ``hist``."""
    n_hist = hist.size
    for m in range(out.size):
        acc = 0.0
        for t in range(h.size):
            i = _UP * m - t
            acc += h[t] * (y[i] if i >= 0 else hist[n_hist + i])
        out[m] = gain * acc
    _push(hist, y)


@numba.njit(cache=True, nogil=True, inline="always")
def _push(hist, x):  # pragma: no cover - compiled
    """``hist`` <- the last ``hist.size`` samples of ``hist`` followed by ``x``."""
    n, k = hist.size, x.size
    if k >= n:
        for i in range(n):
            hist[i] = x[k - n + i]
    else:
        for i in range(n - k):
            hist[i] = hist[i + k]
        for i in range(k):
            hist[n - k + i] = x[i]


class Resampler16to48:
    """Streaming 16 kHz <-> 48 kHz resampling for libraries that run at 48 kHz.

    ``up`` zero-stuffs by 3 and low-pass filters (97-tap linear-phase FIR, 7.6 kHz cutoff,
    Kaiser beta 8, gain 3); ``down`` filters with the same FIR and keeps every third sample.
    Both are polyphase (compiled loops): ``up`` applies the three 33/32-tap sub-filters to the
    16 kHz samples (no multiplications by the stuffed zeros), ``down`` computes only the kept
    samples.  Each filter keeps the input samples it still needs, and every output sample is the
    same sum in the same order whatever the block sizes, so frames resampled one after another
    equal the whole signal resampled at once, bit for bit.  Delay: 48 samples at 48 kHz per
    filter, 32 samples at 16 kHz for the round trip.

    >>> r = Resampler16to48()
    >>> x = np.sin(2 * np.pi * 1000 * np.arange(320) / 16000)
    >>> y = r.down(r.up(x))           # 1 kHz in the pass band: back with the 32-sample delay
    >>> bool(np.max(np.abs(y[100:] - x[100 - 32:-32])) < 1e-3)
    True
    """

    DELAY_16K = 2 * (_N_TAPS - 1) // 2 // _UP
    """Round-trip delay of the two FIRs in 16 kHz samples (32)."""

    def __init__(self):
        self.hist_up = np.zeros(_HIST_UP)
        self.hist_down = np.zeros(_HIST_DOWN)

    def up(self, x16: np.ndarray) -> np.ndarray:
        """``(k,)`` samples at 16 kHz -> ``(3k,)`` at 48 kHz (float64)."""
        x16 = np.ascontiguousarray(x16, dtype=np.float64)
        out = np.empty(x16.size * _UP)
        self.up_into(x16, out)
        return out

    def up_into(self, x16: np.ndarray, out: np.ndarray, gain: float = 1.0,
                lo: float = -np.inf, hi: float = np.inf) -> None:
        """``out[:] = clip(gain * up(x16), lo, hi)`` without allocating: ``x16`` contiguous float64
        ``(k,)``, ``out`` contiguous ``(3k,)`` (float32 for a library's input buffer)."""
        _up_kernel(x16, self.hist_up, _up_phases(), out, float(gain), float(lo), float(hi))

    def down(self, y48: np.ndarray, gain: float = 1.0) -> np.ndarray:
        """``(3k,)`` samples at 48 kHz -> ``(k,)`` at 16 kHz (float64), times ``gain``."""
        y48 = np.ascontiguousarray(y48)
        if y48.size % _UP:
            raise ValueError(f"down takes a multiple of {_UP} samples, got {y48.size}")
        out = np.empty(y48.size // _UP)
        _down_kernel(y48, self.hist_down, _lowpass(), out, float(gain))
        return out


@dataclass
class _FrameState:
    engine: Any  # the library's own state (one per stream)
    pending: np.ndarray  # (k,) input samples of the incomplete frame, k < F
    queue: np.ndarray  # (m,) output samples not yet returned


class FramedBlackBox(Enhancer):
    """Base class: one channel in and out, fixed frames of ``frame_samples`` at ``FS``.

    Subclasses set ``frame_samples``, ``library_delay_samples`` (the library's own delay,
    measured) and implement ``_open()`` (a fresh library state) and
    ``_run_frame(engine, frame) -> frame`` on ``(F,)`` float64 arrays in full-scale units.
    """

    FS: ClassVar[int] = 16000
    frame_samples: ClassVar[int] = 160
    library_delay_samples: ClassVar[int] = 0

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1, streaming=True, supported_fs=(self.FS,),
                    latency_samples=self.frame_samples - 1 + self.library_delay_samples,
                    replayable=False)

    def _open(self) -> Any:  # pragma: no cover - subclasses implement
        raise NotImplementedError

    def _run_frame(self, engine: Any, frame: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _init_state(self, fs: int) -> _FrameState:
        return _FrameState(engine=self._open(), pending=np.zeros(0),
                           queue=np.zeros(self.frame_samples - 1))

    def _process_block(self, block: np.ndarray, state: _FrameState):
        f = self.frame_samples
        data = np.concatenate([state.pending, block[0]])
        n_full = data.size // f
        done = [self._run_frame(state.engine, data[i * f:(i + 1) * f]) for i in range(n_full)]
        queue = np.concatenate([state.queue, *done]) if done else state.queue
        n = block.shape[-1]
        out = queue[:n].copy()[None]
        return out, _FrameState(engine=state.engine, pending=data[n_full * f:].copy(), queue=queue[n:].copy())

    def _process(self, x: np.ndarray, fs: int) -> Result:
        out, _ = self._process_block(x, self._init_state(fs))
        return Result(output=out, trace={})
