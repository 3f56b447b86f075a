"""RNNoise (Valin 2018) as a black-box peer, through the ``pyrnnoise`` package.

Optional: ``pip install -e '.[rnnoise]'`` (``pyrnnoise``, Apache-2.0 wrapper; the bundled
``librnnoise.so`` is Xiph's BSD-licensed RNNoise with its model weights compiled in, so
nothing is fetched at run time).  Only the C library is called (through the ctypes
handle ``pyrnnoise.rnnoise.lib``): pyrnnoise's own file/stream helpers are not used.

RNNoise runs at 48 kHz on 10 ms frames (480 samples) of float samples in int16 units.
This wrapper takes 16 kHz audio: each 10 ms frame (160 samples) is upsampled by 3
(zero-stuffing and a 97-tap linear-phase low-pass, 7.6 kHz cutoff, Kaiser beta 8),
denoised, low-pass filtered by the same FIR and decimated by 3
(:class:`enhancers.peers.blackbox.Resampler16to48`, polyphase; both filters keep their state
across frames, so the resampling streams).

Latency (declared in ``tags``): 159 samples of frame buffering + 32 (the two FIRs, 2 x 48
samples at 48 kHz) + 320 (RNNoise's own delay, 20 ms: measured, the output's
cross-correlation with speech peaks there for every CMU ARCTIC utterance tried) = 511
samples, checked in the tests.  Not replayable: measured by phase inversion.

RNNoise's network was trained on real speech: it treats the built-in artificial voice
(the speech of a sweep without ``--data-dir``) largely as noise -- in a smoke-like sweep
STOI fell by 0.3-0.7 with it, but by 0.00-0.05 with CMU ARCTIC speech (``--data-dir``).
Benchmark it with real speech.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pyrnnoise.rnnoise import lib as _lib

from enhancers.core.base import Params
from enhancers.peers.blackbox import INT16_SCALE, FramedBlackBox, Resampler16to48

__all__ = ["RNNoise"]


class _Engine:
    """One RNNoise stream: the C state, the two resampling filters' states and the 48 kHz buffers (made once)."""

    def __init__(self):
        self.handle = _lib.rnnoise_create(None)
        self.resampler = Resampler16to48()
        self.buf_in = np.zeros(3 * 160, dtype=np.float32)
        self.buf_out = np.zeros(3 * 160, dtype=np.float32)
        self.ptr_in = self.buf_in.ctypes.data_as(ctypes.POINTER(ctypes.c_float))
        self.ptr_out = self.buf_out.ctypes.data_as(ctypes.POINTER(ctypes.c_float))

    def __del__(self):
        handle, self.handle = getattr(self, "handle", None), None
        if handle:
            _lib.rnnoise_destroy(handle)

    def frame(self, x16: np.ndarray) -> np.ndarray:
        """``(160,)`` float64 full scale at 16 kHz -> the same; RNNoise takes int16 units, clipped."""
        self.resampler.up_into(x16, self.buf_in, INT16_SCALE, -INT16_SCALE, INT16_SCALE - 1.0)
        _lib.rnnoise_process_frame(self.handle, self.ptr_out, self.ptr_in)
        return self.resampler.down(self.buf_out, 1.0 / INT16_SCALE)


class RNNoise(FramedBlackBox):
    """RNNoise (``pyrnnoise``'s bundled library) at 48 kHz behind 16 kHz <-> 48 kHz resampling.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((1, 16000))
    >>> RNNoise().process(x, 16000).output.shape
    (1, 16000)
    """

    name: ClassVar[str] = "rnnoise"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "RNNoise (pyrnnoise; black box, 48 kHz with 16 kHz resampling)"
    frame_samples: ClassVar[int] = 160
    library_delay_samples: ClassVar[int] = Resampler16to48.DELAY_16K + 320  # FIRs + RNNoise (measured)

    @dataclass(frozen=True)
    class Params(Params):
        """No parameters (RNNoise has none)."""

    def _open(self) -> _Engine:
        return _Engine()

    def _run_frame(self, engine: _Engine, frame: np.ndarray) -> np.ndarray:
        return engine.frame(frame)
