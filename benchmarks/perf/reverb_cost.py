"""Cost of the reverberation metrics per row (issue 10), against the row without them.

    python -m benchmarks.perf.reverb_cost [--seconds 4] [--runs 5]

A reverberant scene like the ``reverb`` preset's (5 x 4 x 2.8 m, RT60 0.6 s, talker 1 m at
60 deg, point noise 1.5 m at 200 deg, 5 dB; seeded speech-like harmonic complex): the
speech-part split (once per geometry), ``srmr`` of one signal, the reverberation input
columns (once per mixture: SINR/DRR/C50 + SRMR) and ``evaluate_enhancer`` with and without
the parts (per enhancer row: replay of 4 parts + SRMR of the output) for ``eb-ss`` and
``passthrough``.  Median of ``--runs`` runs after a warm-up; the peer is the same row without
reverberation metrics, in the same process, so the ratio is what a sweep row pays.
"""

from __future__ import annotations

import argparse

import numpy as np

import enhancers
from benchmarks.metrics import speech as M
from benchmarks.metrics.evaluate import evaluate_enhancer, input_metrics
from benchmarks.metrics.srmr import srmr
from benchmarks.perf.timing import median_time
from scenesim.room.reverb_parts import speech_parts
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import NoiseSource, Scene, SourcePlacement, render_images
from scenesim.scene.geometry import MicPair

FS = 16000


def _case(seconds: float):
    t = np.arange(int(seconds * FS)) / FS
    s = 0.1 * np.clip(np.sin(2 * np.pi * 4 * t), 0, None) ** 2
    s = s * sum(np.sin(2 * np.pi * 150 * k * t) / k for k in range(1, 20))
    scene = Scene(
        fs=FS,
        pair=MicPair((2.0, 1.8, 0.9), axis_azimuth_deg=90.0),
        room=ShoeBox((5.0, 4.0, 2.8), rt60_s=0.6),
        speech=SourcePlacement(60.0, 1.0),
        noises=(NoiseSource(azimuth_deg=200.0, distance_m=1.5),),
        far_field=False,
        reference="early50",
        snr_db=5.0,
    )
    images = render_images(scene, s, [np.random.default_rng(0).standard_normal(t.size)])
    return images, s


def _wall(func, runs: int) -> float:
    return median_time(func, runs)[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    images, s = _case(args.seconds)
    parts = speech_parts(images, s)
    rendered = images.mix()
    inputs = input_metrics(rendered)
    with_reverb = input_metrics(rendered, speech_parts=parts, reference="early50")
    print(f"# reverberation metrics cost on {args.seconds:g} s at {FS} Hz, median of {args.runs} runs")
    print(f"{'what':44s} {'median s':>9s} {'peer s':>9s} {'ratio':>7s}")

    def line(name, func, peer):
        t = _wall(func, args.runs)
        p = _wall(peer, args.runs) if peer is not None else None
        print(f"{name:44s} {t:9.4f} {p if p is not None else float('nan'):9.4f} {t / p if p else float('nan'):7.2f}")

    mix0 = rendered.mixture[0]
    line("speech_parts (per geometry) / render_images", lambda: speech_parts(images, s), lambda: _case(args.seconds))
    line("srmr (one signal) / pesq_scores nb+wb", lambda: srmr(mix0, FS), lambda: M.pesq_scores(rendered.reference[0], mix0, fs=FS))
    line("input metrics + reverb columns / without", lambda: input_metrics(rendered, speech_parts=parts, reference="early50"), lambda: input_metrics(rendered))
    for name in ("eb-ss", "passthrough"):
        line(
            f"evaluate_enhancer {name}: with parts / without",
            lambda n=name: evaluate_enhancer(enhancers.make(n), rendered, input_metrics=with_reverb, speech_parts=parts),
            lambda n=name: evaluate_enhancer(enhancers.make(n), rendered, input_metrics=inputs),
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
