"""CPU cost of DNSMOS P.835 against PESQ (narrow-band + wide-band), per clip length.

    python -m benchmarks.perf.dnsmos_cost [--seconds 2 6 10] [--runs 3]

DNSMOS (:mod:`benchmarks.metrics.dnsmos`, one ONNX session per process with one intra-op thread)
repeats a clip shorter than 9.01 s until it is not and scores 9.01 s windows 1 s apart, so
its cost depends on the length: 2 s -> 16 s -> 7 windows, 6 s -> 12 s -> 3, 10 s -> 1.
PESQ is ``benchmarks.metrics.speech.pesq_scores`` (both modes).  Median CPU time of ``--runs``
runs after a warm-up (which opens the ONNX session).  The verdict: DNSMOS is opt-in per
sweep (``metrics = ["dnsmos"]``) when it costs more than PESQ.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.metrics.dnsmos import dnsmos_p835
from benchmarks.metrics.speech import pesq_scores
from benchmarks.perf.timing import median_time

FS = 16000


def measure(seconds_list, runs: int = 3) -> list[dict]:
    rng = np.random.default_rng(5)
    rows = []
    for seconds in seconds_list:
        t = np.arange(int(seconds * FS)) / FS
        clean = 0.05 * rng.standard_normal(t.size) * (1 + np.sin(2 * np.pi * 3 * t))
        noisy = clean + 0.01 * rng.standard_normal(t.size)
        dn = median_time(lambda x=noisy: dnsmos_p835(x, FS), runs)[1]
        pq = median_time(lambda c=clean, x=noisy: pesq_scores(c, x, fs=FS), runs)[1]
        rows.append({"seconds": seconds, "dnsmos_cpu_s": dn, "pesq_cpu_s": pq})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, nargs="+", default=[2.0, 6.0, 10.0])
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args(argv)
    print("| clip (s) | DNSMOS cpu (s) | PESQ nb+wb cpu (s) | DNSMOS / PESQ | DNSMOS cpu per s of audio |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    for r in measure(args.seconds, args.runs):
        print(f"| {r['seconds']:g} | {r['dnsmos_cpu_s']:.3f} | {r['pesq_cpu_s']:.3f} | "
              f"{r['dnsmos_cpu_s'] / r['pesq_cpu_s']:.1f} | {r['dnsmos_cpu_s'] / r['seconds']:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
