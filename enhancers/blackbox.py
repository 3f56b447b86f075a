"""Frame-buffered wrapper for black-box peers (external libraries that process fixed frames).

A library such as WebRTC's noise suppressor or RNNoise takes exactly ``F`` samples per
call (10 ms) and keeps its own opaque state.  :class:`FramedBlackBox` turns it into a
streaming enhancer with the project's time alignment (:mod:`enhancers.base`): input is
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

import numpy as np
from scipy.signal import firwin, lfilter

from enhancers.base import Enhancer, Result, Tags

__all__ = ["FramedBlackBox", "Resampler16to48", "to_int16_scale"]

INT16_SCALE = 32768.0
"""Full scale (|x| = 1) in the int16 units the libraries take."""


def to_int16_scale(x: np.ndarray) -> np.ndarray:
    """Full-scale float samples to int16 units, clipped to the int16 range (float64 result)."""
    return np.clip(np.asarray(x, dtype=float) * INT16_SCALE, -INT16_SCALE, INT16_SCALE - 1.0)


_UP = 3
_RATE_LIB = 48000
_N_TAPS = 97  # (97 - 1) / 2 = 48 samples of delay per filter at 48 kHz: a whole 16 kHz sample count


@functools.lru_cache(maxsize=1)
def _lowpass() -> np.ndarray:
    return firwin(_N_TAPS, 7600.0, window=("kaiser", 8.0), fs=_RATE_LIB)


class Resampler16to48:
    """Streaming 16 kHz <-> 48 kHz resampling for libraries that run at 48 kHz.

    ``up`` zero-stuffs by 3 and low-pass filters (97-tap linear-phase FIR, 7.6 kHz cutoff,
    Kaiser beta 8, gain 3); ``down`` filters with the same FIR and keeps every third sample.
    Both filters keep their state across calls (``scipy.signal.lfilter`` with ``zi``), so
    frames resampled one after another equal the whole signal resampled at once.  Delay:
    48 samples at 48 kHz per filter, 32 samples at 16 kHz for the round trip.
    """

    DELAY_16K = 2 * (_N_TAPS - 1) // 2 // _UP
    """Round-trip delay of the two FIRs in 16 kHz samples (32)."""

    def __init__(self):
        self.zi_up = np.zeros(_N_TAPS - 1)
        self.zi_down = np.zeros(_N_TAPS - 1)

    def up(self, x16: np.ndarray) -> np.ndarray:
        """``(k,)`` samples at 16 kHz -> ``(3k,)`` at 48 kHz (float64)."""
        up = np.zeros(x16.size * _UP)
        up[::_UP] = x16
        up, self.zi_up = lfilter(_UP * _lowpass(), 1.0, up, zi=self.zi_up)
        return up

    def down(self, y48: np.ndarray) -> np.ndarray:
        """``(3k,)`` samples at 48 kHz -> ``(k,)`` at 16 kHz (float64)."""
        down, self.zi_down = lfilter(_lowpass(), 1.0, np.asarray(y48, dtype=np.float64), zi=self.zi_down)
        return down[::_UP]


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
