"""How much of a WOLA enhancer's 10 ms streaming cost is the filter bank: streaming vs its floors.

    python -m benchmarks.perf.stream_floor [--only NAME ...] [--runs 3] [--seconds 10]

For each filter-bank enhancer (16 ms frames, 8 ms hop) on the audio of ``enhancer_rtf``, CPU
real-time factors of: batch ``process``; streaming ``process_block`` in 160-sample blocks; the
filter bank's own streaming steps on the same blocks with unit gains (``analysis_step`` +
``synthesis_step``: what the enhancer cannot avoid without a faster filter bank); and the bare
numpy FFT calls of those steps (one ``rfft`` of the input channels and one ``irfft`` per
frame: the floor of any per-frame streaming on numpy's FFT).  Each is also given over batch:
a floor above 5 means streaming <= 5x batch (issue 20) cannot be met on top of it.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from benchmarks.perf.enhancer_rtf import FS, _make, _signal
from benchmarks.perf.timing import median_time

WOLA = ("ss", "ss-ms2001", "mmse-lsa", "superdirective", "eb-ss")
BLOCK = 160


def _filterbank(e):
    """The enhancer's (last stage's, for a chain) filter bank and its input channel count."""
    stages = getattr(e, "stage_enhancers", (e,))
    for stage in reversed(stages):
        if hasattr(stage, "filterbank"):
            return stage.filterbank, stage.tags.channels_in
    raise ValueError(f"{e.name} has no filter bank")


def floors(name: str, *, seconds: float, runs: int) -> dict:
    """CPU real-time factors of batch, streaming, the filter bank alone and the FFT calls alone."""
    e = _make(name)
    x = _signal(seconds, e.tags.channels_in)
    fb, n_in = _filterbank(e)
    xf = x[:n_in]

    def stream():
        st = e.init_state(FS)
        for i in range(0, x.shape[-1], BLOCK):
            _, st = e.process_block(x[:, i:i + BLOCK], st)

    def bank():
        ana, syn = fb.init_state(n_in), fb.init_state(1)
        for i in range(0, xf.shape[-1], BLOCK):
            X, ana = fb.analysis_step(xf[:, i:i + BLOCK], ana)
            _, syn = fb.synthesis_step(X[:1], BLOCK, syn)

    frame = np.zeros((n_in, 1, fb.frame_len))

    def ffts():
        for _ in range(xf.shape[-1] // fb.hop):
            X = np.fft.rfft(frame, axis=-1)
            np.fft.irfft(X[:1], n=fb.frame_len, axis=-1)

    out = {}
    for key, fn in (("batch", lambda: e.process(x, FS)), ("stream", stream), ("bank", bank), ("fft", ffts)):
        out[key] = median_time(fn, runs)[1] / seconds
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", default=list(WOLA))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print("| enhancer | batch RTF (cpu) | streaming RTF (cpu) | filter bank alone | FFT calls alone "
          "| streaming / batch | filter bank / batch | FFT / batch |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in args.only:
        r = floors(name, seconds=args.seconds, runs=args.runs)
        b = r["batch"]
        print(f"| {name} | {b:.4f} | {r['stream']:.4f} | {r['bank']:.4f} | {r['fft']:.4f} "
              f"| {r['stream'] / b:.1f} | {r['bank'] / b:.1f} | {r['fft'] / b:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
