"""Cost of the metrics per condition (the floor of a sweep; algorithms.md section 8).

    python -m benchmarks.perf.metrics_cost [--seconds 10] [--runs 5]

On a real rendered scene (scenesim free field, the thesis geometry: a seeded speech-like
harmonic complex with syllabic modulation at 45 deg, white noise at 270 deg, 5 dB): each
metric function, ``input_metrics`` (once per mixture) and ``evaluate_enhancer`` with the
registered ``eb-ss`` (every output metric, replay SNR).  Median of ``--runs`` runs after one
warm-up.  Stated costs: PESQ ~0.15-0.2 s per call on 10 s, STOI ~0.07 s.  The peer column is
a numpy ``rfft``/``irfft`` round trip of the same audio in the same process, so a busy
machine shows as a large peer time too (timings on a shared 2-core machine are noisy).
"""

from __future__ import annotations

import argparse

import numpy as np

import enhancers
from benchmarks.metrics import speech as M
from benchmarks.metrics.evaluate import evaluate_enhancer, input_metrics
from benchmarks.perf.timing import median_time
from scenesim.scene.compose import Scene, render_scene

FS = 16000


def _scene(seconds: float, rng: np.random.Generator):
    """The thesis geometry rendered by scenesim (speech 45 deg, point noise 270 deg, 5 dB)."""
    t = np.arange(int(seconds * FS)) / FS
    s = 0.1 * np.clip(np.sin(2 * np.pi * 4 * t), 0, None) ** 2
    s = s * sum(np.sin(2 * np.pi * 150 * k * t) / k for k in range(1, 20))
    return render_scene(Scene(fs=FS, snr_db=5.0), s, [rng.standard_normal(t.size)])


def _wall(func, runs: int) -> float:
    return median_time(func, runs)[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    sc = _scene(args.seconds, np.random.default_rng(0))
    ref, deg = sc.reference[0], sc.mixture[0]
    inputs = input_metrics(sc)
    cases = {
        "snr_db": lambda: M.snr_db(sc.speech_image[0], sc.noise_image[0]),
        "segmental_snr_db": lambda: M.segmental_snr_db(ref, deg, fs=FS),
        "si_sdr_db": lambda: M.si_sdr_db(ref, deg),
        "estimate_lag (±512)": lambda: M.estimate_lag(deg, ref, max_lag=512),
        "pesq_scores (nb + wb)": lambda: M.pesq_scores(ref, deg, fs=FS),
        "stoi_scores (stoi + estoi)": lambda: M.stoi_scores(ref, deg, fs=FS),
        "input_metrics": lambda: input_metrics(sc),
        "evaluate_enhancer (eb-ss)": lambda: evaluate_enhancer(
            enhancers.make("eb-ss"), sc, input_metrics=inputs
        ),
    }
    peer = _wall(lambda: np.fft.irfft(np.fft.rfft(deg), deg.size), args.runs)
    print(f"# metrics cost on {args.seconds:g} s at {FS} Hz, median of {args.runs} runs")
    print(f"{'what':32s} {'median s':>10s} {'x peer':>10s}")
    for name, func in cases.items():
        t = _wall(func, args.runs)
        print(f"{name:32s} {t:10.4f} {t / peer:10.1f}")
    print(f"{'peer: rfft+irfft':32s} {peer:10.5f} {1:10.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
