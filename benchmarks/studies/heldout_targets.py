"""Issues 30 / 31: the talker-blind front end's targets on a split it was not chosen on.

    python -m benchmarks.studies.heldout_targets [--split test] [--seeds 10] [--first-seed 0]
        [--data-dir DIR] [--systems NAME ...] [--set NAME.KEY=JSON ...] [--skip-mismatch] [--out DIR]

Runs the ``phone`` preset's conditions at input SNR >= 15 dB (15, 20, 25 dB; every noise; seeds
``S .. S + N - 1`` of split ``--split``) through the project's runner (one worker) for the front ends
(``eb-spp``, ``eb-robust-blind``, ``mvdr``, ``mwf``), their ``-ss`` chains, the frozen baselines
``eb-robust@1`` / ``eb-robust-ss@1``, ``superdirective`` and ``ss``, and prints, from the stored rows:

1. per system: the share of rows with ``speech_jitter_db <= -30`` dB and the worst row (target for a front
   end: >= 98 %, none above -20 dB; a chain ending in ``ss`` is reported beside ``ss``, not held to it),
   and the share whose replay and Hagerman SNR-I are within 3 dB (target >= 95 %);
2. per noise and system, the paired difference against its baseline over the conditions (seeds x SNRs)
   with the lower 95 % bound (Student t, :func:`benchmarks.report.compare.paired_ci`): a front end against
   ``eb-robust@1`` and a ``-ss`` chain against ``eb-robust-ss@1``, in SNR-I (target: lower bound >= -1 dB;
   for the ``-ss`` chain also >= -0.5 dB) and in raw PESQ (``pesq_nb_out``; ``-ss`` chain: >= -0.05);
   with ``superdirective`` among ``--systems``, ``mvdr`` / ``mwf`` (any version, e.g. ``mvdr@1``) against it
   too (target: lower bound >= 0);
3. issue 12's mismatch loss (:func:`benchmarks.studies.robust_eb.snr_improvements`: a 1 dB / 5 deg rear
   mic against ideal mics, 135 / 240 deg babble, diffuse babble, wind; target loss <= 2 dB).

``--set NAME.KEY=JSON``: a parameter of one system for this run (e.g. a tuned parameter set's values;
table 3 uses them too).
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile

import numpy as np

from benchmarks.report.compare import paired_ci
from benchmarks.run.sweep import load_sweep
from benchmarks.studies.noise_stats import (
    AGREE_DB,
    JITTER_DB,
    SNRS,
    parse_sets,
    per_system,
    run_rows,
)
from benchmarks.studies.robust_eb import snr_improvements

FRONT = ("eb-spp", "eb-robust-blind", "mvdr", "mwf")
CHAINS = ("eb-spp-ss", "eb-robust-blind-ss", "mvdr-ss")
BASE, BASE_SS = "eb-robust@1", "eb-robust-ss@1"
SYSTEMS = (BASE, *FRONT, "superdirective", BASE_SS, *CHAINS, "ss")
WORST_DB, AGREE_SHARE, JITTER_SHARE = -20.0, 0.95, 0.98
MISMATCH_SYSTEMS, LOSS_DB = ("eb-spp", BASE), 2.0


def targets_sweep(*, split: str, seeds: int, first_seed: int, systems, sets=None):
    """The ``phone`` sweep on ``split`` restricted to :data:`SNRS`, ``systems`` and seeds ``first_seed ..``."""
    sweep = load_sweep("phone").with_split(split).with_seeds(seeds)
    sweep = dataclasses.replace(sweep, enhancers=tuple(systems), axes={**sweep.axes, "snr_db": SNRS},
                                enhancer_params=sets or {})
    return sweep.with_seed(first_seed) if first_seed else sweep


def jitter_lines(df, systems) -> list[str]:
    """Table 1 of the module docstring (Markdown lines)."""
    lines = [f"| system | rows | jitter <= {JITTER_DB:g} dB | worst (dB) | median (dB) | replay~Hagerman "
             f"within {AGREE_DB:g} dB | front-end targets met |", "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for name, g, j, agreed in per_system(df, systems):
        agree = np.mean(agreed)
        met = "n/a (ends in ss)" if name.endswith("ss") else (
            "yes" if np.mean(j <= JITTER_DB) >= JITTER_SHARE and np.nanmax(j) <= WORST_DB and agree >= AGREE_SHARE
            else "no")
        lines.append(f"| {name} | {len(g)} | {np.mean(j <= JITTER_DB):.0%} | {np.nanmax(j):.1f} | "
                     f"{np.nanmedian(j):.1f} | {agree:.0%} | {met} |")
    return lines


def _bound(g, base, name, column):
    piv = g.pivot_table(index="condition_id", columns="enhancer", values=column).dropna()
    if base not in piv or name not in piv:
        return None
    return paired_ci(list(piv[base]), list(piv[name]))


def comparisons(systems) -> list[tuple[str, str, float, float | None]]:
    """``(system, baseline, SNR-I bound, raw PESQ bound or None)`` of table 2: a front end against
    ``eb-robust@1`` (-1 dB), a ``-ss`` chain against ``eb-robust-ss@1`` (-0.5 dB, -0.05 PESQ), and the
    adaptive MVDR / MWF against the fixed ``superdirective`` (0 dB: issue 31's "not by standing still").

    >>> comparisons(["eb-robust@1", "eb-spp", "mvdr@1", "superdirective", "ss"])
    [('eb-spp', 'eb-robust@1', -1.0, None), ('mvdr@1', 'eb-robust@1', -1.0, None), ('mvdr@1', 'superdirective', 0.0, None)]
    """
    out = []
    for name in systems:
        if name in (BASE, BASE_SS, "ss", "superdirective"):
            continue
        chain = name.endswith("-ss")
        out.append((name, BASE_SS, -0.5, -0.05) if chain else (name, BASE, -1.0, None))
        if name.split("@")[0] in ("mvdr", "mwf") and "superdirective" in systems:
            out.append((name, "superdirective", 0.0, None))
    return out


def paired_lines(df, systems) -> list[str]:
    """Table 2 of the module docstring: mean difference and lower 95 % bound per noise (Markdown lines)."""
    lines = ["| noise | system | baseline | SNR-I diff (lower 95 %) | raw PESQ diff (lower 95 %) | target |",
             "| --- | --- | --- | ---: | ---: | --- |"]
    for noise, g in df.groupby("noise"):
        for name, base, need, need_pesq in comparisons(systems):
            snr, pesq = _bound(g, base, name, "snr_i_db"), _bound(g, base, name, "pesq_nb_out")
            if snr is None or snr.ci_low is None:
                continue
            ok = snr.ci_low >= need and (need_pesq is None or (pesq is not None and pesq.ci_low >= need_pesq))
            ptxt = "n/a" if pesq is None or pesq.ci_low is None else f"{pesq.mean_diff:+.3f} ({pesq.ci_low:+.3f})"
            goal = f"SNR-I >= {need:g}" + ("" if need_pesq is None else f", PESQ >= {need_pesq:g}")
            lines.append(f"| {noise} | {name} | {base} | {snr.mean_diff:+.2f} ({snr.ci_low:+.2f}) | {ptxt} | "
                         f"{goal}: {'met' if ok else 'NOT met'} |")
    return lines


def mismatch_lines(names=MISMATCH_SYSTEMS, *, seconds: float = 20.0, settle_s: float = 8.0,
                   sets=None) -> list[str]:
    """Table 3: SNR-I with ideal and 1 dB / 5 deg mismatched mics and the loss (target <= 2 dB)."""
    rows = snr_improvements(names, seconds=seconds, settle_s=settle_s, params=sets)
    lines = ["| noise | system | ideal SNR-I | 1 dB / 5 deg SNR-I | loss (dB) | target |",
             "| --- | --- | ---: | ---: | ---: | --- |"]
    by = {(r[0], r[1]): r[2:] for r in rows}
    for kind in dict.fromkeys(r[0] for r in rows):
        ideal, mism = by[(kind, "0 dB / 0 deg")], by[(kind, "1 dB / 5 deg")]
        for name, a, b in zip(names, ideal, mism):
            goal = "n/a (wind)" if kind == "wind" else ("met" if a - b <= LOSS_DB else "NOT met")
            lines.append(f"| {kind} | {name} | {a:.2f} | {b:.2f} | {a - b:+.2f} | {goal} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="test", choices=("dev", "test", "all"), help="data split (default test)")
    ap.add_argument("--seeds", type=int, default=10, help="number of seeds (default 10)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--data-dir", default=None, help="speech/noise directory (default: built-in data)")
    ap.add_argument("--systems", nargs="*", default=list(SYSTEMS), help="systems (default: those above)")
    ap.add_argument("--set", nargs="*", default=[], metavar="NAME.KEY=JSON", help="a system's parameter")
    ap.add_argument("--skip-mismatch", action="store_true", help="leave out table 3")
    ap.add_argument("--out", default=None, help="store directory to keep (default: a temporary one)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0:
        ap.error(f"--seeds {args.seeds} / --first-seed {args.first_seed}: need seeds >= 1 and first seed >= 0")
    try:
        sets = parse_sets(args.set)
    except ValueError as e:
        ap.error(str(e))
    sweep = targets_sweep(split=args.split, seeds=args.seeds, first_seed=args.first_seed, systems=args.systems,
                          sets=sets)
    with tempfile.TemporaryDirectory(prefix="heldout-") as tmp:
        df = run_rows(sweep, args.out or tmp, args.data_dir)
    print(f"phone at {', '.join(f'{s:g}' for s in SNRS)} dB, split {args.split}, seeds {args.first_seed}.."
          f"{args.first_seed + args.seeds - 1}, data {args.data_dir or 'built-in'}, settings {sets}\n")
    print("\n".join(jitter_lines(df, args.systems)) + "\n")
    print("\n".join(paired_lines(df, args.systems)))
    if not args.skip_mismatch:
        print("\n" + "\n".join(mismatch_lines(sets=sets)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
