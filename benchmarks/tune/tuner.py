"""``scenesim tune`` as a function: search on dev, write the parameter set, run it once on test.

:func:`tune` reads a :class:`TuneSettings`, searches the enhancer's parameters with
:func:`benchmarks.tune.study.optimize` on the sweep's ``dev`` material (:mod:`.trials`), writes
``DIR/params.toml`` (:mod:`.paramset`), then runs the chosen parameters on ``test`` material
with seeds after the dev seeds and writes ``DIR/tune_report.md`` / ``.csv`` (:mod:`.holdout`).
Each test run increments the study's ``test_evaluations`` (kept in ``DIR/optuna.db`` and in
``params.toml``): the second look at test makes it a dev set, and the run says so.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from benchmarks.run.executors import check_workers
from benchmarks.tune.holdout import REPORT_METRICS, dev_test_table, write_report
from benchmarks.tune.objective import Constraint, Objective
from benchmarks.tune.overlap import count_overlap, material_labels
from benchmarks.tune.paramset import (
    PARAMS_FILE,
    ParameterSet,
    data_fingerprint,
    save_parameter_set,
    versions,
)
from benchmarks.tune.space import parse_space
from benchmarks.tune.study import (
    best_trial,
    counted,
    feasible,
    open_study,
    optimize,
    require_optuna,
    storage_url,
)
from benchmarks.tune.trials import (
    SweepEvaluation,
    dev_sweep,
    seeds_of,
    split_of,
    splits_supported,
    test_sweep,
)
from scenesim.errors import DataError, ParameterError
from scenesim.validate import check_choice, check_int

#: Trials of one study: TPE's cost grows with the history, and each trial runs a sweep.
MAX_TRIALS = 10_000

DIRECTIONS = ("maximize", "minimize")


@dataclass(frozen=True)
class TuneSettings:
    """What ``scenesim tune`` was asked (see ``scenesim tune --help`` for each option)."""

    enhancer: str
    sweep: Any  # preset name, TOML path or Sweep
    params: Sequence[str]
    objective: str
    out_dir: Path
    trials: int = 50
    direction: str = "maximize"
    constraints: Sequence[str] = ()
    seeds: int | None = None
    seed: int | None = None
    test_seeds: int | None = None
    sampler_seed: int = 0
    data_dir: Path | None = None
    limit: int | None = None
    workers: int | None = None
    run_test: bool = True


@dataclass(frozen=True)
class TuneOutcome:
    params_file: Path
    parameter_set: ParameterSet
    report_files: tuple[Path, ...] = ()
    test_evaluations: int = 0


@dataclass(frozen=True)
class _Plan:
    """The settings read and checked: everything the search needs, before any trial runs."""

    dims: tuple
    objective: Objective
    constraints: tuple[Constraint, ...]
    dev: Any
    dev_seeds: list[int]
    n_conditions: int
    data: dict[str, str]
    data_dir: str | None


def _plan(s: TuneSettings) -> _Plan:
    from benchmarks.run.runner import _select_conditions
    from enhancers.core.registry import get

    require_optuna()
    check_choice("--direction", s.direction, DIRECTIONS)
    dims = parse_space(s.params, get(s.enhancer).Params, enhancer=s.enhancer)
    objective = Objective.parse(s.objective)
    constraints = tuple(Constraint.parse(c) for c in s.constraints)
    check_int("trials", s.trials, minimum=1, maximum=MAX_TRIALS)
    check_workers(s.workers)
    sweep, _ = _select_conditions(s.sweep, seed=s.seed, limit=s.limit, seeds=s.seeds)
    dev = dev_sweep(sweep)
    conditions = _select_conditions(dev, seed=None, limit=s.limit)[1]
    if s.run_test and s.test_seeds is not None:  # the test run's size, before any trial runs
        try:
            test_sweep(dev, seeds_of(conditions), s.test_seeds)
        except ParameterError as exc:
            raise ParameterError("test_seeds", s.test_seeds, exc.allowed) from None
    data_dir = str(s.data_dir) if s.data_dir else (os.environ.get("SCENESIM_DATA") or None)
    return _Plan(dims, objective, constraints, dev, seeds_of(conditions), len(conditions),
                 data_fingerprint(data_dir), data_dir)


def _config(s: TuneSettings, p: _Plan) -> dict[str, Any]:
    """What a resumed study must share with the stored one (else the directory is refused)."""
    import hashlib

    return {"enhancer": s.enhancer, "search_space": [d.text for d in p.dims], "objective": p.objective.text,
            "direction": s.direction, "constraints": [c.text for c in p.constraints],
            "sweep": p.dev.name, "sweep_sha256": hashlib.sha256(p.dev.text.encode()).hexdigest(),
            "split": split_of(p.dev), "seeds": p.dev_seeds, "limit": s.limit, "sampler_seed": s.sampler_seed,
            **p.data}


def tune(s: TuneSettings, *, log: Callable[[str], None] | None = None) -> TuneOutcome:
    """Search, write ``params.toml``, then (``run_test``) evaluate once on test and report."""
    log = log or _stderr
    p = _plan(s)
    out = Path(s.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    config = _config(s, p)
    study = open_study(out, name=f"scenesim-tune-{s.enhancer}", direction=s.direction, seed=s.sampler_seed,
                       constrained=bool(p.constraints), config=config)
    _announce(s, p, study, log)
    evaluation = SweepEvaluation(p.dev, s.enhancer, p.objective, p.constraints, out, data_dir=p.data_dir,
                                 limit=s.limit, workers=s.workers, log=log)
    optimize(study, evaluation, p.dims, trials=s.trials, out_dir=out, log=log, label=f"tune {s.enhancer}")
    best = best_trial(study)
    if best is None:
        first = next((t.user_attrs.get("fail_reason") for t in counted(study)), "no trial ran")
        raise DataError(f"no trial of {s.enhancer} completed ({first})")
    if not feasible(best):
        log(f"scenesim: warning: no trial met every constraint; the least violating (#{best.number}) is kept")
    n_looks = int(study.user_attrs.get("test_evaluations", 0))
    dev_rows = evaluation.rows(best.params)  # its store is complete: read back, not rerun
    pset = ParameterSet(f"{s.enhancer}-tuned", s.enhancer, dict(best.params),  # dev_files: what later runs are checked against
                        {**_provenance(s, p, config, study, best, n_looks), "dev_files": material_labels(dev_rows)})
    params_file = save_parameter_set(out / PARAMS_FILE, pset)
    if not s.run_test:
        return TuneOutcome(params_file, pset, (), n_looks)
    return _holdout(s, p, study, evaluation, pset, params_file, dev_rows, log)


def _announce(s: TuneSettings, p: _Plan, study, log) -> None:
    n_done = len(counted(study))
    seeds = f"{p.dev_seeds[0]}..{p.dev_seeds[-1]}" if len(p.dev_seeds) > 1 else str(p.dev_seeds[0])
    log(f"tune {s.enhancer}: {s.trials} trials ({n_done} done) of {p.n_conditions} {split_of(p.dev)} "
        f"conditions each, seeds {seeds}; study {storage_url(s.out_dir)} "
        "(optuna-dashboard opens it)")
    if not splits_supported(p.dev):
        log("scenesim: warning: this checkout's sweeps have no dev/test split: the search and the test "
            "run draw the same speech and noise material; only their seeds differ")


def _provenance(s: TuneSettings, p: _Plan, config, study, best, n_looks: int) -> dict[str, Any]:
    return {
        **{k: v for k, v in config.items() if v is not None},
        "constraint_value": "worst violation over the selected rows, in the column's unit (<= 0: met)",
        "trials": s.trials,
        "trials_counted": len(counted(study)),
        "best_trial": best.number,
        "best_value": float(best.value),
        "feasible": feasible(best),
        "sweep_source": str(p.dev.source),
        "sampler": "optuna.samplers.TPESampler",
        "study": storage_url(s.out_dir),
        "created_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "test_evaluations": n_looks,
        "versions": versions(),
    }


def _holdout(s: TuneSettings, p: _Plan, study, evaluation: SweepEvaluation, pset: ParameterSet,
             params_file: Path, dev_rows: list[dict], log) -> TuneOutcome:
    """Run ``pset`` once on test (seeds after the dev seeds), count the look, write the report."""
    n_test = s.test_seeds or len(p.dev_seeds)
    test = test_sweep(p.dev, p.dev_seeds, n_test)
    test_rows = evaluation.rows(pset.params, sweep=test, where=Path(s.out_dir) / "test")
    n_looks = int(study.user_attrs.get("test_evaluations", 0)) + 1
    study.set_user_attr("test_evaluations", n_looks)
    test_seeds = seeds_of(test.conditions())
    pset = ParameterSet(pset.name, pset.enhancer, pset.params,
                        {**pset.provenance, "test_evaluations": n_looks, "test_seeds": test_seeds,
                         "test_split": split_of(test)})
    save_parameter_set(params_file, pset)
    if n_looks > 1:
        log(f"scenesim: warning: test has been looked at {n_looks} times for this study: its numbers "
            "now inform choices and are no longer held out")
    metrics = (p.objective.column, *(c.test.column for c in p.constraints), *REPORT_METRICS)
    table = dev_test_table(dev_rows, test_rows, metrics, seed=s.sampler_seed)
    header = _report_header(s, p, pset, test_seeds, n_looks)
    leak = count_overlap(pset.name, test_rows, pset.provenance, lambda row: p.data["data"])
    if leak.in_sample:  # the test run is built disjoint from dev; if it ever is not, say so first
        header = [f"**⚠ {leak.banner()}**", "", *header]
        log(f"scenesim: warning: {leak.banner()}")
    lines = [f"- `{c.text}`: dev {c.value(dev_rows):+.3g}, test {c.value(test_rows):+.3g} "
             f"({len(c.selected(test_rows))} test rows)" for c in p.constraints]
    files = write_report(s.out_dir, table, header, lines)
    return TuneOutcome(params_file, pset, files, n_looks)


def _report_header(s: TuneSettings, p: _Plan, pset: ParameterSet, test_seeds, n_looks: int) -> list[str]:
    shown = ", ".join(f"{k} = {v!r}" for k, v in pset.params.items())
    return [
        f"Enhancer `{s.enhancer}` with {shown} (trial #{pset.provenance['best_trial']} of "
        f"{pset.provenance['trials_counted']}), objective `{p.objective.text}` ({s.direction}).",
        f"Dev: split `{split_of(p.dev)}`, seeds {p.dev_seeds}; test: split "
        f"`{pset.provenance['test_split']}`, seeds {test_seeds}; data {p.data['data']}.",
        f"Test has been evaluated {n_looks} time(s) for this study"
        + ("." if n_looks == 1 else ": it is no longer held out."),
    ]


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
