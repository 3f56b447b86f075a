"""Issue 31 targets for the adaptive baselines: jitter, replay/Hagerman agreement, and mvdr against superdirective.

    python -m benchmarks.studies.noise_stats [--seeds N] [--first-seed S] [--data-dir DIR]
        [--systems NAME ...] [--set NAME.KEY=JSON ...] [--out DIR]

Runs the ``phone`` preset's conditions at input SNR >= 15 dB (15, 20, 25 dB; every noise; seeds
``S .. S + N - 1``) through the project's runner (:func:`benchmarks.run.runner.run_sweep`, one worker,
into ``--out`` or a temporary store) for ``mvdr``, ``mwf``, ``mvdr-ss``, ``superdirective``,
``eb-robust``, ``eb-robust-ss`` (or ``--systems``), and prints from the stored rows, per system:

1. the share of rows with ``speech_jitter_db <= -30`` dB and the worst row;
2. the share of rows whose replay SNR-I (``snr_i_db``) and Hagerman SNR-I (``snr_i_hagerman_db``)
   are within 3 dB;
3. per noise, the mean SNR-I of each system and the paired difference ``mvdr - superdirective``
   over the conditions (seeds x SNRs) with its lower 95 % bound (Student t,
   :func:`benchmarks.report.compare.paired_ci`); issue 31's target is a lower bound >= 0.

``--set NAME.KEY=JSON``: a parameter of one system for this run, e.g. ``--set 'mvdr.spp="single"'``
(a dev-split comparison of a setting).  Choose settings on seeds and data you do not report.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
from collections import defaultdict

import numpy as np

from benchmarks.report.compare import paired_ci
from benchmarks.run.runner import run_sweep
from benchmarks.run.sweep import load_sweep
from benchmarks.store.frame import load_results

SYSTEMS = ("mvdr", "mwf", "mvdr-ss", "superdirective", "eb-robust", "eb-robust-ss")
SNRS = (15.0, 20.0, 25.0)
JITTER_DB, AGREE_DB = -30.0, 3.0


def parse_sets(items) -> dict[str, dict]:
    """``{"mvdr": {"spp": "single"}}`` from ``["mvdr.spp=\\"single\\""]``; ValueError naming a bad item.

    >>> parse_sets(['mvdr.spp="single"', "mwf.mu=2"])
    {'mvdr': {'spp': 'single'}, 'mwf': {'mu': 2}}
    """
    out: dict[str, dict] = defaultdict(dict)
    for item in items:
        key, sep, text = item.partition("=")
        name, dot, param = key.partition(".")
        try:
            if not (sep and dot and name and param):
                raise ValueError("expected NAME.KEY=JSON")
            out[name][param] = json.loads(text)
        except ValueError as e:
            raise ValueError(f"--set {item!r}: expected NAME.KEY=JSON, e.g. mvdr.spp='\"single\"' ({e})") from None
    return dict(out)


def study_sweep(*, seeds: int, first_seed: int, systems, sets: dict):
    """The ``phone`` sweep restricted to :data:`SNRS`, ``systems`` and seeds ``first_seed .. + seeds - 1``."""
    unknown = sorted(set(sets) - set(systems))
    if unknown:
        raise ValueError(f"--set names {unknown[0]!r}, which is not among the systems {list(systems)}")
    sweep = load_sweep("phone").with_seeds(seeds)
    sweep = dataclasses.replace(sweep, enhancers=tuple(systems), enhancer_params=sets,
                                axes={**sweep.axes, "snr_db": SNRS})
    return sweep.with_seed(first_seed) if first_seed else sweep


def run_rows(sweep, out_dir, data_dir):
    """Run ``sweep`` into ``out_dir`` with one worker and return its ok rows (a DataFrame)."""
    run_sweep(sweep, out_dir, workers=1, data_dir=data_dir, report=None, progress=False, listen_count=0)
    return load_results(out_dir, ok_only=True)


def per_system(df, systems):
    """``(name, rows, jitter (n,), replay~Hagerman within AGREE_DB (n,) bool)`` of each system with rows."""
    for name in systems:
        g = df[df.enhancer == name]
        if len(g):
            j = g.speech_jitter_db.to_numpy(float)
            yield name, g, j, np.abs(g.snr_i_db.to_numpy(float) - g.snr_i_hagerman_db.to_numpy(float)) <= AGREE_DB


def summary_lines(df, systems) -> list[str]:
    """The three tables of the module docstring, as Markdown lines."""
    lines = [f"| system | rows | jitter <= {JITTER_DB:g} dB | worst jitter (dB) | replay~Hagerman within "
             f"{AGREE_DB:g} dB |", "| --- | ---: | ---: | ---: | ---: |"]
    for name, g, j, agree in per_system(df, systems):
        lines.append(f"| {name} | {len(g)} | {np.mean(j <= JITTER_DB):.0%} | {np.nanmax(j):.1f} | {np.mean(agree):.0%} |")
    lines += ["", "| noise | " + " | ".join(systems) + " | mvdr - superdirective (lower 95 %) |",
              "| --- |" + " ---: |" * (len(systems) + 1)]
    for noise, g in df.groupby("noise"):
        means = [g[g.enhancer == s].snr_i_db.mean() for s in systems]
        cell = ""
        if {"mvdr", "superdirective"} <= set(systems):
            piv = g.pivot_table(index="condition_id", columns="enhancer", values="snr_i_db").dropna()
            st = paired_ci(list(piv["superdirective"]), list(piv["mvdr"]))
            low = "n/a" if st.ci_low is None else f"{st.ci_low:+.2f}"
            cell = f"{st.mean_diff:+.2f} ({low}, n={st.n})"
        lines.append(f"| {noise} | " + " | ".join(f"{m:.2f}" for m in means) + f" | {cell} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="number of seeds (default 2)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--data-dir", default=None, help="speech/noise directory (default: built-in data)")
    ap.add_argument("--systems", nargs="*", default=list(SYSTEMS), help="systems (default: the six above)")
    ap.add_argument("--set", nargs="*", default=[], metavar="NAME.KEY=JSON", help="a system's parameter")
    ap.add_argument("--out", default=None, help="store directory to keep (default: a temporary one)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0:
        ap.error(f"--seeds {args.seeds} / --first-seed {args.first_seed}: need seeds >= 1 and first seed >= 0")
    try:
        sweep = study_sweep(seeds=args.seeds, first_seed=args.first_seed, systems=args.systems,
                            sets=parse_sets(args.set))
    except ValueError as e:
        ap.error(str(e))
    with tempfile.TemporaryDirectory(prefix="noise-stats-") as tmp:
        df = run_rows(sweep, args.out or tmp, args.data_dir)
    print(f"phone at {', '.join(f'{s:g}' for s in SNRS)} dB, seeds {args.first_seed}.."
          f"{args.first_seed + args.seeds - 1}, data {args.data_dir or 'built-in'}, settings {json.dumps(parse_sets(args.set))}\n")
    print("\n".join(summary_lines(df, args.systems)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
