"""Issue 15 part 5: a black-box peer at its operating point -- RNNoise's int16 input level and
the gain of its 16 <-> 48 kHz resampling, with the library replaced by the identity."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

rnnoise = pytest.importorskip("enhancers.peers.rnnoise", reason="pyrnnoise not installed (extra 'rnnoise')")

FS = 16000


class _IdentityLibrary:
    """Stands in for librnnoise: copies each 480-sample frame and records its peak."""

    def __init__(self):
        self.peaks: list[float] = []

    def rnnoise_create(self, _model):
        return 1

    def rnnoise_destroy(self, _handle):
        pass

    def rnnoise_process_frame(self, _handle, out_ptr, in_ptr):
        frame = np.ctypeslib.as_array(ctypes.cast(in_ptr, ctypes.POINTER(ctypes.c_float)), shape=(480,))
        self.peaks.append(float(np.max(np.abs(frame))))
        ctypes.memmove(out_ptr, in_ptr, 480 * 4)
        return 0.0


def test_rnnoise_sees_int16_units_and_its_resampling_has_unit_gain(monkeypatch):
    # Oracles: the library's contract (float frames in int16 units: a -20 dBFS sine peaks at
    # 0.1 x 32768) and transparency -- with an identity library the wrapper must return the
    # input, delayed by its declared latency minus RNNoise's own 320 samples: a 1 kHz sine
    # (well inside the 7.6 kHz pass band) keeps its amplitude within 0.05 dB.
    lib = _IdentityLibrary()
    monkeypatch.setattr(rnnoise, "_lib", lib)
    t = np.arange(FS) / FS
    x = 0.1 * np.sin(2 * np.pi * 1000.0 * t)
    enh = rnnoise.RNNoise()
    y = enh.process(x[None, :], FS).output[0]
    steady = np.array(lib.peaks[20:])
    np.testing.assert_allclose(steady, 0.1 * 32768, rtol=0.01)
    delay = enh.tags.latency_samples - 320
    out = y[delay + 2000 :]
    ref = x[2000 : x.size - delay]
    gain_db = 20 * np.log10(np.std(out) / np.std(ref))
    assert abs(gain_db) < 0.05, gain_db
    assert np.max(np.abs(out - ref)) < 0.01 * 0.1  # and in phase: the delay is the declared one
