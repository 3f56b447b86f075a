"""Sweep overhead and scaling: the full ``thesis`` preset against the cost of its metric calls.

The unavoidable cost of a sweep is its metric calls (PESQ narrow- and wide-band and STOI
on every input and output signal).  This script measures

1. the wall time ``W_n`` of ``scenesim bench run thesis --workers n --no-report`` in a fresh
   process, for n = 1 and 2 (fresh store each time);
2. the wall time ``M_n`` of the metric calls alone: the same signals (each condition's
   mixture and each enhancer's latency-aligned output against the reference), PESQ nb + wb
   + STOI per signal, spread over the same number of warm worker processes;

and prints ``overhead = W_n / M_n - 1`` (target <= 25 %) and ``speedup = W_1 / W_2``
(target >= 1.7).  The target is judged against the floor with ESTOI, because the sweep
computes ESTOI too: that floor holds every metric call the sweep makes and nothing else.
Signals the sweep does not score (an enhancer output identical to its input, whose scores
are the input's) are not in the floor either.

Usage::

    python -m benchmarks.perf.sweep_overhead [--preset thesis] [--data-dir DIR] [--out DIR]
        [--repeats 1]

A full thesis run takes minutes, so ``--repeats`` defaults to 1 (the median is printed
when more).  Timings on a machine shared with other jobs are noisy: say so when quoting.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def _signal_pairs(preset: str, data_dir: str | None) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """``(reference, estimate, fs)`` for every metric call of the sweep (inputs and outputs)."""
    from benchmarks.run.runner import plan_conditions
    from benchmarks.run.sweep import load_sweep
    from benchmarks.run.worker import ConditionTask, build_enhancer, render_group

    sweep = load_sweep(preset)
    pairs = []
    for task in plan_conditions(sweep, sweep.conditions(), set(), data_dir):
        task: ConditionTask
        cond = task.condition
        images, _, _ = render_group(cond, data_dir)
        rendered = images.mix(cond.snr_db)
        ref = np.asarray(rendered.reference, dtype=np.float64)[0]
        mix = np.asarray(rendered.mixture, dtype=np.float64)
        pairs.append((ref, mix[0], cond.fs))
        for spec in task.enhancers:
            enh = build_enhancer(spec, cond)
            x = mix[: enh.tags.channels_in]
            y = enh.process(x, cond.fs).output[0]
            lat = int(enh.tags.latency_samples)
            if lat == 0 and np.array_equal(y, mix[0]):
                continue  # the sweep reuses the input scores for an unchanged signal (passthrough)
            pairs.append((ref[: ref.size - lat], y[lat:], cond.fs))
    return pairs


def _metric_calls(pair, with_estoi: bool = False) -> float:
    """PESQ nb + PESQ wb + STOI (+ ESTOI) on one pair; returns its CPU-side wall time."""
    from pesq import pesq
    from pystoi import stoi

    ref, est, fs = pair
    t0 = time.perf_counter()
    pesq(fs, ref, est, "nb")
    if fs == 16000:
        pesq(fs, ref, est, "wb")
    stoi(ref, est, fs, extended=False)
    if with_estoi:
        stoi(ref, est, fs, extended=True)
    return time.perf_counter() - t0


def _metrics_with_estoi(pair) -> float:
    return _metric_calls(pair, with_estoi=True)


def _warm(_):
    import pesq  # noqa: F401
    import pystoi  # noqa: F401

    return os.getpid()


def metric_floor(pairs, workers: int, *, with_estoi: bool = False) -> float:
    """Wall time of the metric calls alone on ``workers`` warm worker processes.

    Workers start like the sweep's (fork server, single-threaded BLAS), so the floor is
    measured under the same conditions as the sweep's own metric calls.
    """
    import multiprocessing

    from benchmarks.run.executors import SINGLE_THREAD_ENV, _environ

    fn = _metrics_with_estoi if with_estoi else _metric_calls
    ctx = multiprocessing.get_context("forkserver")
    with _environ(SINGLE_THREAD_ENV), ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        list(pool.map(_warm, range(workers)))
        t0 = time.perf_counter()
        list(pool.map(fn, pairs, chunksize=1))
        return time.perf_counter() - t0


def sweep_wall(preset: str, workers: int, data_dir: str | None, out: Path) -> float:
    """Wall time of ``scenesim bench run PRESET --workers N --no-report`` in a fresh process.

    A fresh interpreter for every run: 1 and 2 workers both pay imports and first-call
    set-up (nothing is warm from an earlier run in this process).
    """
    cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", preset, "--out", str(out),
           "--workers", str(workers), "--no-report"]  # fmt: skip
    if data_dir:
        cmd += ["--data-dir", data_dir]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"sweep failed ({proc.returncode}):\n{proc.stderr}")
    return wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--preset", default="thesis")
    parser.add_argument("--data-dir", default=os.environ.get("SCENESIM_DATA") or None)
    parser.add_argument("--out", type=Path, default=None, help="keep the 2-worker store + report here")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args(argv)
    data_dir = str(Path(args.data_dir).resolve()) if args.data_dir else None

    print(f"preset {args.preset}, data {data_dir or 'built-in'}, cpu_count {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.2f} (shared machine: timings are noisy)")  # fmt: skip
    walls: dict[int, list[float]] = {1: [], 2: []}
    keep = None
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            for n in (1, 2):
                out = Path(tmp) / f"w{n}-{r}"
                if n == 2 and args.out is not None and r == args.repeats - 1:
                    out = args.out
                    keep = out
                walls[n].append(sweep_wall(args.preset, n, data_dir, out))
                print(f"  sweep, {n} worker(s), run {r + 1}: {walls[n][-1]:.1f} s")
        pairs = _signal_pairs(args.preset, data_dir)
        floors = {}
        for n in (1, 2):
            floors[n] = statistics.median(metric_floor(pairs, n) for _ in range(args.repeats))
            floors[(n, "estoi")] = statistics.median(
                metric_floor(pairs, n, with_estoi=True) for _ in range(args.repeats)
            )
    w1, w2 = statistics.median(walls[1]), statistics.median(walls[2])
    print()
    print(f"{len(pairs)} metric signal pairs (inputs + enhancer outputs the sweep scores)")
    print("| workers | sweep wall (s) | metric floor PESQ nb+wb+STOI (s) | overhead | floor + ESTOI (s) | overhead vs it |")
    print("|---|---|---|---|---|---|")
    for n, w in ((1, w1), (2, w2)):
        f, fe = floors[n], floors[(n, "estoi")]
        print(f"| {n} | {w:.1f} | {f:.1f} | {100 * (w / f - 1):+.0f} % | {fe:.1f} | {100 * (w / fe - 1):+.0f} % |")
    print()
    print(f"speedup 1 -> 2 workers: {w1 / w2:.2f}x (target >= 1.7x); "
          f"overhead at 2 workers vs all its metric calls (PESQ nb+wb, STOI, ESTOI): "
          f"{100 * (w2 / floors[(2, 'estoi')] - 1):.0f} % (target <= 25 %)")  # fmt: skip
    if keep is not None:
        from benchmarks.report.from_store import write_store_report

        files = write_store_report(keep)
        print(f"store and report of the 2-worker run: {keep} ({len(files)} report files)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
