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
the benchmark measures them by phase inversion (``benchmarks.evaluate``: outputs for
``s + n`` and ``s - n``).  They need no declared conformance expected failures: the
replay checks apply only to replayable enhancers, and every other check (streaming ==
batch, state isolation, determinism, silence, pickling of the enhancer) holds because the
library state lives in the stream state, one per stream.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from enhancers.base import Enhancer, Result, Tags

__all__ = ["FramedBlackBox", "to_int16_scale"]

INT16_SCALE = 32768.0
"""Full scale (|x| = 1) in the int16 units the libraries take."""


def to_int16_scale(x: np.ndarray) -> np.ndarray:
    """Full-scale float samples to int16 units, clipped to the int16 range (float64 result)."""
    return np.clip(np.asarray(x, dtype=float) * INT16_SCALE, -INT16_SCALE, INT16_SCALE - 1.0)


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
