"""``scenesim bench run | report | compare | list``: run sweeps, write reports, compare stores, list what is available."""

from __future__ import annotations

import argparse
import contextlib
import sqlite3
import sys
from pathlib import Path

from benchmarks.cli.checks import (
    check_store_readable,
    corrupt_store_error,
    options_named,
    prepare_out_dir,
)
from benchmarks.run.executors import check_workers
from benchmarks.run.lock import run_lock
from benchmarks.run.progress import slow_rir_warning
from benchmarks.run.signals import sigterm_as_interrupt
from scenesim.errors import ConfigError, ParameterError

#: Shown where PESQ appears (bench list, README install section): licence and install needs.
PESQ_NOTICE = (
    "source-only on PyPI (pip compiles it: needs a C compiler) and bundles the ITU-T P.862 "
    "reference code, whose licence restricts use to evaluation"
)


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "bench",
        help="run benchmark sweeps, write reports, list presets/enhancers/noises",
        description="Benchmark speech enhancers over sweeps of simulated scenes.",
    )
    sub = p.add_subparsers(dest="bench_command", metavar="ACTION", required=True)

    run = sub.add_parser(
        "run",
        help="run a sweep (resumable: rerunning computes only what is missing)",
        description="Run a sweep (a preset name or a TOML file) into DIR/results.sqlite and "
        "write DIR/report.  Rerunning on the same --out computes only what is missing.",
    )
    run.add_argument("sweep", metavar="PRESET_OR_TOML", help="a preset (scenesim bench list) or a sweep .toml file")
    run.add_argument("--out", required=True, metavar="DIR", help="output directory (store + report)")
    run.add_argument("--executor", choices=("local", "dask"), default="local", help="where to run (default: local)")
    run.add_argument("--workers", type=_positive_int, default=None, metavar="N", help="worker processes (default: CPU count)")
    run.add_argument("--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://10.0.0.5:8786 (with --executor dask)")
    run.add_argument("--data-dir", type=Path, default=None, metavar="DIR", help="speech/noise directory (default: $SCENESIM_DATA, else built-in)")
    run.add_argument("--limit", type=_positive_int, default=None, metavar="N", help="run only N conditions, spread over every swept axis (noise, SNR, seed, ...)")
    run.add_argument("--seeds", type=_positive_int, default=None, metavar="N", help="replace the sweep's seed list by 0..N-1 (more seeds: tighter intervals)")
    run.add_argument("--seed", type=_nonneg_int, default=None, metavar="S", help="offset the sweep's seeds by S")
    run.add_argument("--split", choices=("dev", "test", "all"), default=None,
                     help="draw speech and noise from this data split (default: the sweep's split key, else all)")
    run.add_argument("--retry-errors", action="store_true", help="recompute rows stored with status 'error'")
    run.add_argument("--no-report", action="store_true", help="do not write DIR/report at the end")
    run.add_argument(
        "--new-version",
        action="store_true",
        help="DIR holds rows of a changed sweep: move them to table results_previous and start over",
    )
    run.set_defaults(func=_run)

    rep = sub.add_parser("report", help="write tables (Markdown, CSV), figures (PNG) and index.html (with audio) from a store")
    rep.add_argument("dir", type=Path, metavar="DIR", help="a directory holding results.sqlite")
    rep.add_argument("--listen", nargs="+", default=(), metavar="CONDITION_ID", help="give these conditions audio players in index.html (default: a spread of noises and SNRs)")
    rep.add_argument("--listen-count", type=_nonneg_int, default=None, metavar="N", help="how many conditions get audio when --listen is not given (default 6; 0: none)")
    rep.set_defaults(func=_report)

    cmp_ = sub.add_parser(
        "compare",
        help="differences (B - A) between two stores of one sweep: its changed parameters, then 95%% CIs over seeds (paired; unpaired when only the seeds differ)",
    )
    cmp_.add_argument("dir_a", type=Path, metavar="DIR_A", help="baseline store directory")
    cmp_.add_argument("dir_b", type=Path, metavar="DIR_B", help="store compared with it")
    cmp_.add_argument("--out", type=Path, default=None, metavar="DIR", help="where compare.csv/.md go (default: DIR_B/compare)")
    cmp_.add_argument("--metrics", nargs="+", default=None, metavar="COLUMN", help="result columns to compare (default: snr_i_db pesq_nb_out pesq_wb_out stoi_out estoi_out si_sdr_out_db)")
    cmp_.add_argument("--all", action="store_true", dest="show_all", help="also print the lines where no metric changed")
    cmp_.set_defaults(func=_compare)

    lst = sub.add_parser("list", help="presets, enhancers (versions, source package) and noise types")
    lst.add_argument("--data-dir", type=Path, default=None, metavar="DIR", help="data directory whose noises to list")
    lst.set_defaults(func=_list)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def _nonneg_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def _run(args) -> int:
    from benchmarks.report.from_store import write_store_report
    from benchmarks.run.runner import _select_conditions, run_sweep

    if args.scheduler and args.executor != "dask":
        raise ParameterError("--scheduler", args.scheduler, "to be used with --executor dask")
    # offset seeds must stay SQLite integers: refused before any work, naming the option typed
    with options_named({"seed": "--seed", "seeds": "--seeds", "limit": "--limit", "workers": "--workers"}):
        check_workers(args.workers)
        sweep, conditions = _select_conditions(args.sweep, seed=args.seed, limit=args.limit, seeds=args.seeds,
                                               split=args.split)
    _check_runnable(sweep, args.data_dir)
    out = prepare_out_dir("--out", args.out)
    slow = slow_rir_warning(conditions)
    if slow:
        print(f"scenesim: warning: {slow}", file=sys.stderr)
    with run_lock(out), sigterm_as_interrupt(), _store_errors(out):
        check_store_readable(out / "results.sqlite")  # a damaged store: say so before writing to it
        _mark_killed_runs(out)
        summary = run_sweep(
            args.sweep,  # as typed: run_sweep applies --seed/--seeds/--limit itself (once)
            out,
            executor=args.executor,
            workers=args.workers,
            scheduler=args.scheduler,
            data_dir=args.data_dir,
            limit=args.limit,
            seed=args.seed,
            seeds=args.seeds,
            split=args.split,
            retry_errors=args.retry_errors,
            report=None if args.no_report else write_store_report,
            new_version=args.new_version,
        )
    for note in summary.warnings:
        print(f"scenesim: warning: {note}", file=sys.stderr)
    print(f"scenesim bench: {sweep.name}: {summary.line()}", file=sys.stderr)
    failed = _failed_rows_line(summary)
    if failed:
        print(failed, file=sys.stderr)
        if summary.n_errors == summary.n_rows:
            return 1
    print(f"results: {summary.store_path}")
    if summary.report_files:
        index = next((f for f in summary.report_files if f.suffix == ".md"), summary.report_files[0])
        print(f"report:  {index}")
        page = next((f for f in summary.report_files if f.name == "index.html"), None)
        if page:
            print(f"page:    {page}")
    if summary.report_error:
        print(
            f"scenesim: error: the report could not be written ({summary.report_error}); the results "
            f"are stored; retry with: scenesim bench report {args.out}",
            file=sys.stderr,
        )
        return 1
    return 0


def _check_runnable(sweep, data_dir) -> None:
    """Refuse before any work: extras the sweep needs and lacks (a run would store empty columns), and a
    data folder chosen explicitly without usable speech (an error there, not a fallback)."""
    missing = sweep.missing_extras()
    if missing:
        raise ConfigError(f"sweep {sweep.name!r} needs what this install lacks: " + "; ".join(missing))
    if data_dir is not None:
        from data_recipes import open_data

        open_data(data_dir, require_speech=True, split=sweep.split)


def _mark_killed_runs(out: Path) -> None:
    """With the lock held, a ``runs`` row still 'running' belongs to a run that was killed."""
    from benchmarks.store.sqlite import STORE_NAME, ResultStore

    if (out / STORE_NAME).is_file():
        with ResultStore.open(out) as store:
            n = store.mark_abandoned_runs()
        if n:
            print(f"scenesim: warning: marked {n} run(s) that ended without finishing as 'killed' "
                  "in the store's runs table; their rows are kept", file=sys.stderr)


def _failed_rows_line(summary) -> str | None:
    """One line when rows of this run failed: all (an error; the caller exits 1) or some (a warning)."""
    if not summary.n_errors:
        return None
    from benchmarks.store.sqlite import ResultStore

    with ResultStore.open(summary.out_dir, readonly=True) as store:
        rows = store.rows("status = 'error' AND run_id = ?", (summary.run_id,))
        first = next((r["error"] for r in rows if r.get("error")), "no message")
    hint = f"first error: {first}; rerun failed rows with --retry-errors"
    if summary.n_errors == summary.n_rows:
        return f"scenesim: error: all {summary.n_rows} rows of this run failed ({hint})"
    return f"scenesim: warning: {summary.n_errors} of {summary.n_rows} rows of this run failed ({hint})"


@contextlib.contextmanager
def _store_errors(out_dir):
    """sqlite's errors on a damaged ``results.sqlite`` as one line saying how to move it aside."""
    from benchmarks.store.sqlite import STORE_NAME

    try:
        yield
    except sqlite3.DatabaseError as exc:
        raise corrupt_store_error(Path(out_dir) / STORE_NAME, exc) from None


def _check_listen_ids(out_dir, ids) -> None:
    """Every ``--listen`` id names a condition of the store (a typo must not give a page without players)."""
    from benchmarks.store.sqlite import ResultStore

    if not ids or not (Path(out_dir) / "results.sqlite").is_file():
        return  # no store: write_store_report says so
    with ResultStore.open(out_dir, readonly=True) as store:
        known = {r["condition_id"] for r in store.rows()}
    missing = [i for i in ids if i not in known]
    if missing:
        some = ", ".join(sorted(known)[:3])
        listed = f": one of its {len(known)}, e.g. {some}" if known else " (it holds none)"
        raise ParameterError("--listen", missing[0], f"a condition id of {Path(out_dir) / 'results.sqlite'}{listed}")


def _report(args) -> int:
    from benchmarks.report.from_store import write_store_report
    from benchmarks.report.listening import DEFAULT_LISTEN_COUNT, ListenOptions

    count = DEFAULT_LISTEN_COUNT if args.listen_count is None else args.listen_count
    with _store_errors(args.dir):
        _check_listen_ids(args.dir, args.listen)
        files = write_store_report(args.dir, listen=ListenOptions(tuple(args.listen), count=count))
    for f in files:
        print(f)
    return 0


def _compare(args) -> int:
    from benchmarks.report.compare import DEFAULT_METRICS, compare_stores

    if args.out is not None:
        prepare_out_dir("--out", args.out, create=False)  # a file there: one line naming --out
    text, files = compare_stores(args.dir_a, args.dir_b, out_dir=args.out, metrics=tuple(args.metrics or DEFAULT_METRICS), show_all=args.show_all)
    print(text)
    for f in files:
        print(f)
    return 0


def _list(args) -> int:
    import os

    from benchmarks.run.sweep import PRESETS, load_sweep
    from enhancers.core.registry import describe

    print("Presets (scenesim bench run NAME):")
    for name in PRESETS:
        sweep = load_sweep(name)
        n = sweep.n_conditions
        print(f"  {name:<9}{n:4d} conditions x {len(sweep.enhancers)} enhancers = {n * len(sweep.enhancers):4d} rows")
        print(f"           {sweep.description}")

    print("\nEnhancers (name, version, source package):")
    for row in describe():
        print(f"  {row['name']:<14} v{row['version']:<6} {row['source']:<20} {row['summary']}")

    print("\nMetrics (every results row):")
    print("  SNR-I (replay), segmental SNR, SI-SDR, STOI/ESTOI (pystoi, MIT),")
    print(f"  PESQ nb/wb (pesq package): {PESQ_NOTICE}")

    data_dir = args.data_dir or os.environ.get("SCENESIM_DATA") or None
    print(f"\nNoise types ({data_dir or 'built-in synthesized noises'}):")
    try:
        from data_recipes import open_data

        ds = open_data(data_dir)
        for t in ds.noise_types():
            print(f"  {t}")
    except Exception as exc:  # listing must keep working when the data dir is broken
        print(f"  (cannot list: {exc})")
    return 0
