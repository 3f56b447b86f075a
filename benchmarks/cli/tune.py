"""``scenesim tune``: search an enhancer's parameters on dev material, then measure them on test."""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks.cli.bench import _nonneg_int, _positive_int
from benchmarks.cli.checks import options_named, prepare_out_dir

_EPILOG = """\
examples:
  scenesim tune ss --sweep phone --param alpha=0.8:0.99 --param subf=0.005:0.1:log \\
      --objective mean:snr_i_db --trials 50 --seeds 3 --limit 20 --out tune-ss
  scenesim tune eb-robust --sweep my.toml --param mu=0.01:0.5:log --objective mean:snr_i_db \\
      --constraint "speech_jitter_db<=-30@snr_in_db>=15" --trials 40 --out tune-eb

--param:       NAME=LO:HI (uniform; an int field searches integers), NAME=LO:HI:log
               (log-uniform, LO > 0), NAME=a,b,c (one of the values); NAME is a field of the
               enhancer's Params (a wrong NAME lists them).
--objective:   AGG:COLUMN, AGG mean or median over the trial's ok rows of a results column.
--constraint:  COLUMN<=V or COLUMN>=V, optionally @COLUMN<=V|>=V to select rows; its value
               is the worst violation over the selected rows (<= 0: met); TPE favours
               trials that meet every constraint, and the best feasible trial is kept.

Trials evaluate the sweep's dev material only (a sweep with split = "test" is refused; an
"all" sweep runs as "dev") on seeds 0..N-1 (+ --seed), each into DIR/trials/<hash>.  The
study is DIR/optuna.db: rerunning the same command after Ctrl-C continues to --trials trials
in total (finished trials are not rerun), and `optuna-dashboard sqlite:///DIR/optuna.db`
shows it.  DIR/params.toml holds the best parameters with their provenance
(benchmarks.tune.load_parameter_set); they are then run once on test material with the next
seeds, and DIR/tune_report.md / .csv give dev against test (optimism, bootstrap 95 % CI).
Every test run is counted in params.toml (test_evaluations); a second look is warned about.
"""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "tune",
        help="tune an enhancer's parameters on dev material (Optuna TPE), then measure them once on test",
        description="Search an enhancer's declared parameters with Optuna's TPE sampler on a sweep's "
        "dev material, write the best as a parameter set with provenance, and report dev against test.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("enhancer", metavar="ENHANCER", help="registered enhancer name (scenesim bench list)")
    p.add_argument("--sweep", required=True, metavar="PRESET_OR_TOML", help="the sweep whose conditions each trial runs")
    p.add_argument("--param", action="append", required=True, metavar="SPEC", help="a searched field: NAME=LO:HI[:log] or NAME=a,b,c (repeat)")
    p.add_argument("--objective", required=True, metavar="AGG:COLUMN", help="e.g. mean:snr_i_db")
    p.add_argument("--direction", choices=("maximize", "minimize"), default="maximize", help="default: maximize")
    p.add_argument("--constraint", action="append", default=[], metavar="SPEC", help="e.g. speech_jitter_db<=-30@snr_in_db>=15 (repeat)")
    p.add_argument("--trials", type=_positive_int, required=True, metavar="N", help="total trials of the study (a rerun continues to N)")
    p.add_argument("--seeds", type=_positive_int, default=None, metavar="N", help="dev seeds 0..N-1 (default: the sweep's)")
    p.add_argument("--seed", type=_nonneg_int, default=None, metavar="S", help="offset the dev seeds by S")
    p.add_argument("--test-seeds", type=_positive_int, default=None, metavar="N", help="seeds of the test run, after the last dev seed (default: as many as dev)")
    p.add_argument("--sampler-seed", type=_nonneg_int, default=0, metavar="S", help="seed of the TPE sampler and of the bootstrap (default 0)")
    p.add_argument("--no-test", action="store_true", help="stop after writing params.toml (test is not looked at)")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="study, trial stores, params.toml, report")
    p.add_argument("--data-dir", type=Path, default=None, metavar="DIR", help="speech/noise directory (default: $SCENESIM_DATA, else built-in)")
    p.add_argument("--limit", type=_positive_int, default=None, metavar="N", help="run only N conditions per trial, spread over the swept axes")
    p.add_argument("--workers", type=_positive_int, default=None, metavar="N", help="worker processes per trial (default: min(conditions, CPUs))")
    p.set_defaults(func=_tune)


def _tune(args) -> int:
    from benchmarks.run.lock import run_lock
    from benchmarks.run.signals import sigterm_as_interrupt
    from benchmarks.tune.study import require_optuna
    from benchmarks.tune.tuner import TuneSettings, tune

    optuna = require_optuna()
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # our own line per trial replaces Optuna's
    if args.data_dir is not None:  # chosen explicitly: unusable speech is an error, not a fallback
        from data_recipes import open_data

        open_data(args.data_dir, require_speech=True)
    out = prepare_out_dir("--out", args.out)
    settings = TuneSettings(
        enhancer=args.enhancer, sweep=args.sweep, params=tuple(args.param), objective=args.objective,
        out_dir=out, trials=args.trials, direction=args.direction, constraints=tuple(args.constraint),
        seeds=args.seeds, seed=args.seed, test_seeds=args.test_seeds, sampler_seed=args.sampler_seed,
        data_dir=args.data_dir, limit=args.limit, workers=args.workers, run_test=not args.no_test,
    )
    with run_lock(out), sigterm_as_interrupt(), options_named({"seed": "--seed", "seeds": "--seeds", "limit": "--limit",
                                                                     "trials": "--trials", "test_seeds": "--test-seeds",
                                                                     "workers": "--workers"}):
        outcome = tune(settings)
    print(f"params: {outcome.params_file}")
    for f in outcome.report_files:
        print(f"report: {f}")
    if outcome.report_files:
        print(outcome.report_files[0].read_text("utf-8"))
    return 0
