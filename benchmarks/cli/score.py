"""``scenesim score DEG... [--ref REF | --pairs LIST] [--out CSV]``: score processed speech.

DEG are files or folders (a folder is one system; its audio files are found recursively).
REF is one reference file for every DEG, or a reference folder paired by path or file stem
(:mod:`benchmarks.metrics.pairing`); ``--pairs`` reads ``ref,deg[,system]`` lines instead.
Each pair is time aligned before scoring (:mod:`benchmarks.metrics.align`): by the delay
``scenesim enhance`` recorded in the file, else by cross-correlation within ``--max-lag-ms``
(500 ms); the lag used is the ``lag_samples`` column (``lag_source``: declared, xcorr, none);
``--no-align`` scores the pair as given.  Every metric that applies is computed
(:mod:`benchmarks.metrics.scoring`).

Output: one CSV row per file (``--out`` or standard output).  With ``--out OUT.csv`` also
``OUT.summary.csv`` (per-system mean, median, 95 % CI over files), ``OUT.paired.csv`` (paired
system-vs-system differences over common utterances, 95 % paired t-interval) and ``OUT.json``
(metric and model versions, options): :mod:`benchmarks.cli.score_eval`.  A file that cannot
be scored gets status ``failed`` and its reason; the batch goes on and the exit status is 1
when any file failed.
"""

from __future__ import annotations

import sys
from pathlib import Path

from benchmarks.cli.checks import check_out_file
from benchmarks.cli.score_eval import output_paths, write_csv, write_evaluation
from benchmarks.metrics.align import DEFAULT_MAX_LAG_S, MAX_LAG_LIMIT_S
from benchmarks.metrics.dnsmos import installed as dnsmos_installed
from benchmarks.metrics.dnsmos import require as require_dnsmos
from benchmarks.metrics.pairing import AUDIO_SUFFIXES, pair_files, read_pair_list
from benchmarks.metrics.scoring import (
    FILE_COLUMNS,
    INTRUSIVE,
    MAX_WORKERS,
    NON_INTRUSIVE,
    ScoreOptions,
    score_pairs,
)
from scenesim.errors import ParameterError

COLUMNS = (*FILE_COLUMNS, *INTRUSIVE, *NON_INTRUSIVE, "error")


def add_parser(subparsers):
    p = subparsers.add_parser(
        "score",
        help="score processed speech (PESQ, STOI, SI-SDR, ... with --ref; SRMR, DNSMOS always)",
        description=(
            "Score processed speech: files or folders (a folder is one system, searched "
            "recursively) against one --ref file, a --ref folder (paired by path or file stem) or "
            "a --pairs list. Pairs are time aligned first (the delay scenesim enhance recorded, "
            "else cross-correlation within --max-lag-ms). With a reference: PESQ nb/wb, STOI, "
            "ESTOI, SI-SDR, segmental SNR; always: SRMR and DNSMOS P.835/P.808 (with the dnsmos "
            "extra). One CSV row per file; --out also writes a per-system summary, paired "
            "comparisons and a versions sidecar. Exit status 1 when a file failed."
        ),
    )
    p.add_argument("degraded", nargs="*", metavar="DEG", help="processed audio file(s) or folder(s)")
    p.add_argument("--ref", default=None, metavar="REF", help="clean reference: one file, or a folder")
    p.add_argument("--pairs", default=None, metavar="LIST",
                   help="CSV list of ref,deg[,system] lines (instead of DEG and --ref)")
    p.add_argument("--out", default=None, metavar="CSV",
                   help="write the rows here, and OUT.summary.csv, OUT.paired.csv, OUT.json beside it")
    p.add_argument("--channel", type=int, default=None, metavar="I",
                   help="score channel I of every file (default: files must be mono)")
    p.add_argument("--trim", action="store_true",
                   help="score the overlap when a file and its reference differ in length by more "
                        "than the lag explains")
    p.add_argument("--no-align", action="store_true", help="score each pair as given (no time alignment)")
    p.add_argument("--max-lag-ms", type=float, default=1000.0 * DEFAULT_MAX_LAG_S, metavar="MS",
                   help=f"bound of the cross-correlation search (default {1000 * DEFAULT_MAX_LAG_S:g} ms)")
    p.add_argument("--workers", type=int, default=1, metavar="N", help="worker processes (default 1)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--dnsmos", action="store_true",
                       help='require DNSMOS (an error without pip install "scenesim[dnsmos]")')
    group.add_argument("--no-dnsmos", action="store_true", help="skip DNSMOS (the slowest metric)")
    p.set_defaults(func=run)
    return p


def _check_values(args) -> None:
    if args.pairs is not None and (args.degraded or args.ref is not None):
        raise ParameterError("--pairs", args.pairs, "a list file alone (its lines name REF and DEG: "
                             "drop DEG and --ref)")
    if args.pairs is None and not args.degraded:
        raise ParameterError("DEG", "", "at least one processed file or folder, or --pairs LIST")
    if args.channel is not None and args.channel < 0:
        raise ParameterError("--channel", args.channel, "a channel index >= 0 (0 = first channel)")
    if not 0 < args.max_lag_ms <= 1000 * MAX_LAG_LIMIT_S:
        raise ParameterError("--max-lag-ms", args.max_lag_ms, f"a bound in (0, {1000 * MAX_LAG_LIMIT_S:g}] ms")
    if not 1 <= args.workers <= MAX_WORKERS:
        raise ParameterError("--workers", args.workers, f"a number of processes in [1, {MAX_WORKERS}]")


def _check_out(out: str, inputs: set[Path]) -> Path:
    path = check_out_file("--out", out)
    if path.suffix.lower() in AUDIO_SUFFIXES:
        raise ParameterError("--out", out, "a CSV file name such as scores.csv (a table, not audio)")
    for role, written in output_paths(path).items():
        if written.resolve() in inputs:
            what = "" if role == "rows" else f" (it would write {written} there)"
            raise ParameterError("--out", out, f"a file that is not one of the inputs{what}; choose another --out")
    return path


def _dnsmos(args) -> bool:
    if args.no_dnsmos:
        return False
    if args.dnsmos:
        require_dnsmos()
        return True
    if not dnsmos_installed():
        print('scenesim score: note: DNSMOS skipped (not installed: pip install "scenesim[dnsmos]"; '
              "--dnsmos makes it an error)", file=sys.stderr)
    return dnsmos_installed()


#: At most this many failed files are named on stderr (all of them are in the rows).
MAX_FAILURES_SHOWN = 10


def _print_failures(rows) -> None:
    """One stderr line per failed file (its path and reason), so a failure is seen without the CSV."""
    bad = [r for r in rows if r["status"] != "ok"]
    for r in bad[:MAX_FAILURES_SHOWN]:
        print(f"scenesim score: failed: {r['file']}: {r['error']}", file=sys.stderr)
    if len(bad) > MAX_FAILURES_SHOWN:
        print(f"scenesim score: ... and {len(bad) - MAX_FAILURES_SHOWN} more failed file(s) (error column)",
              file=sys.stderr)


def run(args) -> int:
    _check_values(args)
    pairs = read_pair_list(args.pairs) if args.pairs is not None else pair_files(args.degraded, args.ref)
    inputs = {p.resolve() for pair in pairs for p in (pair.degraded, pair.reference) if p is not None}
    inputs |= {Path(p).resolve() for p in (args.pairs, args.ref) if p is not None}
    out = _check_out(args.out, inputs) if args.out else None
    options = ScoreOptions(channel=args.channel, trim=args.trim, dnsmos=_dnsmos(args), align=not args.no_align,
                           max_lag_s=args.max_lag_ms / 1000.0)
    rows = score_pairs(pairs, options, workers=args.workers)
    failed = sum(r["status"] != "ok" for r in rows)
    _print_failures(rows)
    counts = f"{len(rows)} file(s): {len(rows) - failed} scored, {failed} failed"
    counts += " (see their error column)" if failed else ""
    if out is None:
        write_csv(sys.stdout, rows, COLUMNS)
        print(f"scenesim score: {counts}; --out CSV also writes the per-system summary and paired "
              "comparisons", file=sys.stderr)
    else:
        paths = write_evaluation(out, rows, COLUMNS, dnsmos=options.dnsmos,
                                 options={**vars(options), "workers": args.workers})
        print(f"{counts} -> {out} (+ {paths['summary'].name}, {paths['paired'].name}, "
              f"{paths['versions'].name})")
    return 1 if failed else 0
