"""Running a sweep (the driver): plan the work, run it on an executor, store rows as units finish.

The work of one condition is :func:`benchmarks.run.worker.run_condition`; this module plans the
tasks (:func:`plan_conditions`, :func:`plan_units`), runs them on an executor and is the only
process that writes the store: one transaction per finished condition, so ``kill -9`` loses
at most the units in flight and a rerun computes only what is missing.  A unit of work
(:class:`~benchmarks.run.worker.UnitTask`) is one condition, or a whole geometry group when
there are enough groups to keep every worker busy.  The runner never imports the report
(it sits below it): a caller that wants one passes a writer, e.g.
:func:`benchmarks.report.from_store.write_store_report`, as ``report``.
"""

from __future__ import annotations

import json
import os
import sys
import time
import warnings
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from benchmarks.excinfo import exc_text as _exc_text
from benchmarks.run.executors import EXECUTORS, make_executor
from benchmarks.run.listen import CLIPS_KEY, DEFAULT_LISTEN_COUNT, listen_ids, save_clips
from benchmarks.run.progress import LineProgress
from benchmarks.run.signals import interrupted
from benchmarks.run.sweep import Condition, Sweep, load_sweep, stratified
from benchmarks.run.versioning import check_version
from benchmarks.run.worker import (  # re-exported: the runner's public names before the split
    ConditionTask,
    EnhancerSpec,
    UnitTask,
    _condition_columns,
    build_enhancer,
    build_scene,
    build_sensors,
    group_parts,
    render_group,
    run_condition,
    run_unit,
    sensor_columns,
)
from benchmarks.store.sqlite import ResultStore
from scenesim.errors import ConfigError, ParameterError
from scenesim.validate import check_choice

WORKER_PRELOAD = ("benchmarks.run.runner", "benchmarks.run.worker", "benchmarks.metrics.evaluate", "data_recipes", "enhancers.core.registry", "scenesim.scene.compose")
"""Modules a local pool's fork server imports once, so its workers start warm."""

@dataclass(frozen=True)
class RunSummary:
    """What :func:`run_sweep` did."""

    out_dir: Path
    store_path: Path
    run_id: str
    n_conditions: int
    n_computed: int
    n_skipped: int
    n_rows: int
    n_errors: int
    wall_s: float
    report_files: tuple[Path, ...] = ()
    report_error: str | None = None
    warnings: tuple[str, ...] = field(default=())

    def line(self) -> str:
        return (
            f"{self.n_conditions} conditions: {self.n_computed} computed, {self.n_skipped} already "
            f"stored; {self.n_rows} rows written ({self.n_errors} with status 'error') "
            f"in {self.wall_s:.1f} s"
        )


# -- the driver side ---------------------------------------------------------------------


def plan_conditions(
    sweep: Sweep,
    conditions: Sequence[Condition],
    done: set[tuple[str, str]],
    data_dir: str | None,
    save_audio: Collection[str] = (),
) -> list[ConditionTask]:
    """One task per condition that misses at least one enhancer's row, in sweep order; the
    conditions whose ids are in ``save_audio`` return their listening clips too."""
    specs = [enhancer_spec(sweep, name) for name in sweep.enhancers]
    tasks = []
    for cond in conditions:
        missing = tuple(s for s in specs if (cond.id, s.name) not in done)
        if missing:
            tasks.append(ConditionTask(cond.to_json(), missing, data_dir, save_audio=cond.id in save_audio))
    return tasks


def enhancer_spec(sweep: Sweep, name: str) -> EnhancerSpec:
    """What builds system ``name`` of ``sweep``: its parameters, and its parameter set's enhancer."""
    base = sweep.registered_name(name)
    params = json.dumps(dict(sweep.enhancer_params.get(name, {})), sort_keys=True)
    return EnhancerSpec(name, params, "" if base == name else base)


def plan_units(tasks: Sequence[ConditionTask], *, workers: int) -> list[UnitTask]:
    """Group condition tasks into units of work.

    With enough geometry groups to keep every worker busy (>= 4 per worker), a unit is a
    whole group: its scene is rendered once, on one worker.  Otherwise each condition is
    a unit (better balance; a group's render may then be repeated on another worker, which
    is cheap next to the metrics).
    """
    groups: dict[str, list[ConditionTask]] = {}
    for t in tasks:
        groups.setdefault(t.condition.group_id, []).append(t)
    if workers > 1 and len(groups) >= 4 * workers:
        return [UnitTask(tuple(g)) for g in groups.values()]
    return [UnitTask((t,)) for t in tasks]


def run_sweep(
    sweep: Sweep | str | Path,
    out_dir: str | Path,
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    data_dir: str | Path | None = None,
    limit: int | None = None,
    seed: int | None = None,
    seeds: int | None = None,
    split: str | None = None,
    retry_errors: bool = False,
    report: Callable[..., Iterable[Path]] | None = None,
    progress: bool = True,
    new_version: bool = False,
    listen_count: int = DEFAULT_LISTEN_COUNT,
) -> RunSummary:
    """Run ``sweep`` (a :class:`Sweep`, preset name or TOML path) into ``out_dir/results.sqlite``.

    Parameters
    ----------
    executor : {"local", "dask"}
        Local process pool (``workers`` default: CPU count; 1 runs in this process), or
        Dask (``scheduler`` address, else a local cluster of ``workers`` processes).
    data_dir : path, optional
        Speech/noise directory; default ``$SCENESIM_DATA``, else the built-in recipes.
    limit : int, optional
        Run only ``limit`` conditions spread over the sweep's axes
        (:func:`benchmarks.run.sweep.stratified`; the first condition is always among them).
    seed : int, optional
        Offset the seeds axis (``seeds = [0]`` becomes ``[seed]``).
    seeds : int, optional
        Replace the sweep's seed list by ``0 .. seeds-1`` (before ``seed`` offsets it).
    split : {"dev", "test", "all"}, optional
        Draw from this data split instead of the sweep's own ``split`` (:meth:`Sweep.with_split`).
        The run's ``options_json`` records the split and the seeds its conditions used.
    retry_errors : bool
        Recompute rows stored with ``status='error'`` (by default they count as done).
    report : callable, optional
        ``report(out_dir, store=store) -> paths``, called at the end to write
        ``out_dir/report`` from every row in the store (the CLI passes
        :func:`benchmarks.report.from_store.write_store_report`); None or False: no report.
    new_version : bool
        The store holds rows of another version of the sweep (any axis or fixed value,
        enhancer or parameter changed): move them to ``results_previous`` and start this
        version (without it such a run is refused, :mod:`benchmarks.run.versioning`).
    progress : bool
        Show a progress bar (only when stderr is a terminal).
    listen_count : int
        Save the audio of this many conditions for the report's listening page
        (:func:`benchmarks.run.listen.listen_ids`, under ``out_dir/listen_audio``; 0: none).

    Returns
    -------
    RunSummary
        Counts, wall time and the report files.  Rows already in the store are not
        recomputed; rerunning after an interruption computes only what is missing.
    """
    check_choice("executor", executor, EXECUTORS)
    sweep, conditions = _select_conditions(sweep, seed=seed, limit=limit, seeds=seeds, split=split)
    data_dir = _resolve_data_dir(data_dir)
    _check_data(conditions, data_dir, sweep.split)

    out_dir = Path(out_dir)
    t_start = time.perf_counter()
    with ResultStore.open(out_dir) as store:
        version = check_version(store, sweep, out_dir=out_dir, new_version=new_version)
        done = store.done_keys(include_errors=not retry_errors)
        tasks = plan_conditions(sweep, conditions, done, data_dir, save_audio=set(listen_ids(conditions, listen_count)))
        _warn_changed_data(store, data_dir, n_kept=len(conditions) - len(tasks))
        run_id = store.start_run(
            sweep=sweep.name,
            source=sweep.source,
            config_toml=sweep.text,
            options={"limit": limit, "seed": seed, "seeds": seeds, "retry_errors": retry_errors, "enhancers": sweep.enhancers,
                     "split": sweep.split, "seeds_used": sorted({c.seed for c in conditions}),
                     **_tuned_option(sweep)},
            executor=executor,
            workers=workers or (None if scheduler else os.cpu_count()),
            scheduler=scheduler,
            data_dir=data_dir,
        )
        tally = _Tally()
        status = "failed"
        try:
            if tasks:
                ex = make_executor(executor, workers=workers, scheduler=scheduler, preload=WORKER_PRELOAD)
                try:
                    _execute(ex, tasks, store, tally, run_id=run_id, version=version, name=sweep.name, progress=progress)
                finally:
                    ex.close()
            status = "finished"
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM under signals.sigterm_as_interrupt
            status = "interrupted"
            raise interrupted(exc, n_written=tally.n_rows, n_stored=len(store.done_keys()), store_path=store.path) from None
        finally:
            store.finish_run(run_id, status=status, n_rows_written=tally.n_rows, n_errors=tally.n_errors)
        report_files, report_error = _try_report(report, out_dir, store) if report else ((), None)
    return RunSummary(
        out_dir=out_dir,
        store_path=store.path,
        run_id=run_id,
        n_conditions=len(conditions),
        n_computed=len(tasks),
        n_skipped=len(conditions) - len(tasks),
        n_rows=tally.n_rows,
        n_errors=tally.n_errors,
        wall_s=time.perf_counter() - t_start,
        report_files=report_files,
        report_error=report_error,
        warnings=tuple(tally.notes),
    )


def _select_conditions(sweep: Sweep | str | Path, *, seed: int | None, limit: int | None, seeds: int | None = None,
                       split: str | None = None):
    """``(sweep, conditions)``: the sweep loaded, its split replaced (``split``), its seed list
    replaced (``seeds``) and offset (``seed``), ``limit`` of its conditions spread over its axes."""
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    if split is not None:
        sweep = sweep.with_split(split)
    if seeds is not None:
        sweep = sweep.with_seeds(seeds)
    if seed is not None:
        sweep = sweep.with_seed(seed)
    conditions = sweep.conditions()
    if limit is not None:
        if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
            raise ParameterError("limit", limit, "an integer >= 1")
        conditions = stratified(conditions, limit, sweep.swept_axes)
    return sweep, conditions


def _tuned_option(sweep: Sweep) -> dict[str, Any]:
    """``{"tuned": {system: provenance}}`` for a sweep with tuned systems, else ``{}`` (the run's
    options then read as before)."""
    from benchmarks.run.parameter_sets import tuned_provenance

    tuned = tuned_provenance(sweep)
    return {"tuned": tuned} if tuned else {}


def _resolve_data_dir(data_dir: str | Path | None) -> str | None:
    """The data directory as an absolute path text: the argument, else ``$SCENESIM_DATA``, else None."""
    if data_dir is None:
        data_dir = os.environ.get("SCENESIM_DATA") or None
    return str(Path(data_dir).resolve()) if data_dir else None


@dataclass
class _Tally:
    """What a run has written so far (rows, error rows, distinct warning texts in order)."""

    n_rows: int = 0
    n_errors: int = 0
    notes: dict[str, None] = field(default_factory=dict)

    def add(self, rows: Sequence[dict[str, Any]], n_written: int) -> None:
        self.n_rows += n_written
        self.n_errors += sum(r.get("status") != "ok" for r in rows)
        for r in rows:
            for note in (r.get("warnings") or "").split("\n"):
                if note:
                    self.notes[note] = None


def _execute(ex, tasks, store: ResultStore, tally: _Tally, *, run_id: str, version: str, name: str, progress: bool) -> None:
    """Run every task on executor ``ex``; write each condition's rows as its unit finishes."""
    units = plan_units(tasks, workers=ex.workers or 1)
    with _progress(len(tasks), name, enabled=progress, workers=ex.workers) as bar:
        for unit, outcome in ex.run(run_unit, units):
            for rows in _rows_of(unit, outcome, run_id, version):
                clips = rows[0].pop(CLIPS_KEY, None) if rows else None
                # one transaction per condition: a kill never leaves half of one
                tally.add(rows, store.write_rows(rows))
                if clips is not None:
                    save_clips(store.path.parent, rows, clips)
            bar.update(len(unit))
            if tally.n_errors:
                bar.set_postfix(errors=tally.n_errors, refresh=False)


def _try_report(write, out_dir: Path, store: ResultStore) -> tuple[tuple[Path, ...], str | None]:
    """``(files, None)``, or ``((), reason)`` when the report fails: the rows are safe in the
    store, so a report failure is said, never raised."""
    try:
        return tuple(write(out_dir, store=store)), None
    except Exception as exc:
        return (), _exc_text(exc)


def _check_data(conditions: Sequence[Condition], data_dir: str | None, split: str = "all") -> None:
    """Fail before starting (not in every worker) on a bad data directory, ``splits.toml`` or
    unknown noise type."""
    from data_recipes import open_data

    for fs in sorted({c.fs for c in conditions}):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # workers report fallbacks in the rows
            ds = open_data(data_dir, fs=fs, split=split)
        for noise in sorted(n for n in {c.noise for c in conditions} if ds.plays(n) is None):
            raise ConfigError(
                f"noise type {noise!r} is neither in the data directory ({ds.description}) nor "
                f"synthesizable, nor a variant '<type>-<name>' of one; available: {', '.join(ds.noise_types())}"
            )


def _rows_of(unit: UnitTask, outcome: Any, run_id: str, version: str | None = None) -> list[list[dict[str, Any]]]:
    """Rows per condition from a unit's outcome; an exception (e.g. Dask's KilledWorker)
    becomes error rows for every condition of the unit."""
    if isinstance(outcome, BaseException):
        per_condition = [_error_rows(task, f"unit failed: {_exc_text(outcome)}") for task in unit.conditions]
    else:
        per_condition = [list(rows) for rows in outcome]
    for rows in per_condition:
        for row in rows:
            row["run_id"] = run_id
            row["sweep_version"] = version
    return per_condition


def _error_rows(task: ConditionTask, message: str) -> list[dict[str, Any]]:
    cond = task.condition
    return [{**_condition_columns(cond), "enhancer": s.name, "status": "error", "error": message} for s in task.enhancers]


def _warn_changed_data(store: ResultStore, data_dir: str | None, *, n_kept: int) -> None:
    """Rows kept from a run on other speech/noise data would mix two data sets: say so."""
    runs = store.runs()
    if not runs or not n_kept:
        return
    before = runs[-1].get("data_dir")
    if before != data_dir:
        warnings.warn(
            f"{n_kept} condition(s) already in the store were computed with data "
            f"{before or 'built-in'} and are kept (now: {data_dir or 'built-in'}); use a new "
            "--out directory to compute everything on the new data",
            stacklevel=3,
        )


class _NullBar:
    def update(self, n=1):
        pass

    def set_postfix(self, **kwargs):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _progress(total: int, name: str, *, enabled: bool, workers: int | None = None):
    if not enabled:
        return _NullBar()
    if not sys.stderr.isatty():  # a log file: tqdm would stay silent; print lines instead
        return LineProgress(total, name, workers=workers)
    from tqdm.auto import tqdm

    # disable=None: tqdm switches itself off when stderr is not a terminal.
    return tqdm(total=total, desc=f"bench {name}", unit="cond", disable=None, file=sys.stderr, dynamic_ncols=True)


__all__ = [
    "EnhancerSpec",
    "RunSummary",
    "enhancer_spec",
    "ConditionTask",
    "UnitTask",
    "build_enhancer",
    "build_scene",
    "build_sensors",
    "group_parts",
    "plan_conditions",
    "plan_units",
    "run_condition",
    "render_group",
    "run_sweep",
    "run_unit",
    "sensor_columns",
]
