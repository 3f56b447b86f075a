"""Running a sweep: split it into units, run them on an executor, store rows as units finish.

A condition (scene x noise x SNR x seed) and the enhancers still missing for it is a
:class:`ConditionTask`; :func:`run_condition` is a pure function of it (condition,
enhancer specs, data directory) -> rows, so any executor gives the same numbers.  Inside
a worker process the rendered scene of a geometry group (everything but the SNR) is kept
in a small cache, so a group is rendered once and only re-mixed per SNR; input metrics
are computed once per mixture, then each enhancer is run and measured.  A unit of work
(:class:`UnitTask`) is one condition, or a whole geometry group when there are enough
groups to keep every worker busy (:func:`plan_units`).

The driver (:func:`run_sweep`) is the only process that writes the store: one
transaction per finished unit, so ``kill -9`` loses at most the units in flight and a
rerun computes only what is missing.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import socket
import sys
import time
import warnings
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from benchmarks.excinfo import exc_text as _exc_text
from benchmarks.executors import EXECUTORS, make_executor
from benchmarks.progress import LineProgress
from benchmarks.signals import interrupted
from benchmarks.store import ResultStore, package_versions
from benchmarks.sweep import Condition, Sweep, load_sweep
from benchmarks.versioning import check_version
from scenesim.errors import ConfigError, ParameterError
from scenesim.geometry import SPEED_OF_SOUND_MPS
from scenesim.validate import check_choice

WORKER_PRELOAD = ("benchmarks.runner", "benchmarks.evaluate", "data_recipes", "enhancers.registry", "scenesim.scene")
"""Modules a local pool's fork server imports once, so its workers start warm."""

# Condition columns every row of a unit carries (the store's names).
_CONDITION_COLUMNS = (
    "noise",
    "rt60_s",
    "speech_az_deg",
    "noise_az_deg",
    "seed",
    "room",
    "distance_m",
    "noise_distance_m",
    "noise_field",
    "fs",
    "duration_s",
    "far_field",
    "spacing_m",
    "wind_speed_mps",
)


@dataclass(frozen=True)
class EnhancerSpec:
    """What a worker needs to build one enhancer: the sweep's name for it and its params."""

    name: str
    params_json: str = "{}"

    @property
    def params(self) -> dict[str, Any]:
        return json.loads(self.params_json)


@dataclass(frozen=True)
class ConditionTask:
    """One condition and the enhancers still to run on it (picklable, small)."""

    condition_json: str
    enhancers: tuple[EnhancerSpec, ...]
    data_dir: str | None = None

    @property
    def condition(self) -> Condition:
        return Condition.from_json(self.condition_json)


@dataclass(frozen=True)
class UnitTask:
    """One unit of work for an executor: one condition, or every condition of a geometry group."""

    conditions: tuple[ConditionTask, ...]

    def __len__(self) -> int:
        return len(self.conditions)


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


# -- the worker side ---------------------------------------------------------------------

_DATASETS: dict[tuple[str | None, int], Any] = {}
_IMAGES: OrderedDict[tuple, Any] = OrderedDict()
_IMAGES_MAX = 2  # a worker interleaves at most a couple of geometry groups


def _dataset(data_dir: str | None, fs: int):
    key = (data_dir, fs)
    if key not in _DATASETS:
        from data_recipes import open_data

        _DATASETS[key] = open_data(data_dir, fs=fs)
    return _DATASETS[key]


def build_sensors(cond: Condition):
    """The condition's sensors: nominal mismatch and self-noise, this seed's production draw.

    None for the thesis' ideal sensors (identical noiseless mics).
    """
    from scenesim.sensors import SensorModel, SensorTolerance

    if cond.ideal_sensors:
        return None
    nominal = SensorModel.from_mismatch(
        gain_db=cond.mic_gain_db,
        phase_deg=cond.mic_phase_deg,
        highpass_hz=cond.mic_highpass_hz,
        self_noise_dba=cond.self_noise_dba,
        speech_spl_db=cond.speech_spl_db,
    )
    tolerance = SensorTolerance(
        gain_tol_db=cond.mic_gain_tol_db,
        phase_tol_deg=cond.mic_phase_tol_deg,
        highpass_tol_hz=cond.mic_highpass_tol_hz,
    )
    return tolerance.draw(nominal, seed=cond.seed)


def sensor_columns(cond: Condition) -> dict[str, Any]:
    """The sensor parameters a row was computed with (drawn values, not the nominal ones)."""
    from scenesim.sensors import SensorModel

    sensors = build_sensors(cond)
    out = (sensors or SensorModel()).describe()
    out["ideal_sensors"] = int(sensors is None)
    out["snr_band_lo_hz"], out["snr_band_hi_hz"] = cond.snr_band_hz or (None, None)
    return out


def build_scene(cond: Condition):
    """The :class:`scenesim.scene.Scene` of a condition (same for every SNR of its group)."""
    from scenesim.geometry import MicPair
    from scenesim.room import ShoeBox
    from scenesim.scene import NoiseSource, Scene, SourcePlacement

    room = None
    if cond.room_dims_m is not None:
        room = ShoeBox(cond.room_dims_m, rt60_s=cond.rt60_s, rt60_method=cond.rt60_method)
    placed = {}  # fields have no place: keep NoiseSource's defaults
    if cond.noise_az_deg is not None:
        placed["azimuth_deg"] = cond.noise_az_deg
    if cond.noise_distance_m is not None:
        placed["distance_m"] = cond.noise_distance_m
    return Scene(
        fs=cond.fs,
        pair=MicPair(cond.pair_center_m, spacing_m=cond.spacing_m, axis_azimuth_deg=cond.axis_azimuth_deg),
        room=room,
        speech=SourcePlacement(azimuth_deg=cond.speech_az_deg, distance_m=cond.distance_m),
        noises=(NoiseSource(field=cond.noise_field, wind_speed_mps=cond.wind_speed_mps, **placed),),
        snr_db=cond.snr_db,
        far_field=cond.far_field,
        snr_mode=cond.snr_mode,
        reference=cond.reference,
        seed=cond.seed,
        sensors=build_sensors(cond),
        snr_band_hz=cond.snr_band_hz,
    )


def _noise_channels(field_type: str) -> int:
    # Diffuse, incoherent and wind fields are built from two independent noise channels;
    # point and spread sources from one recording (spread: disjoint excerpts of it).
    return 1 if field_type in ("point", "spread") else 2


def render_group(cond: Condition, data_dir: str | None):
    """``(SceneImages, speech_source, noise_source)`` of a condition's geometry group (cached)."""
    key = (data_dir, cond.group_id)
    if key in _IMAGES:
        _IMAGES.move_to_end(key)
        return _IMAGES[key]
    from scenesim.scene import render_images

    ds = _dataset(data_dir, cond.fs)
    speech = ds.speech(cond.duration_s, seed=cond.seed)
    noise = ds.noise(cond.noise, cond.duration_s, seed=cond.seed, n_channels=_noise_channels(cond.noise_field))
    images = render_images(build_scene(cond), _mono(speech.signal), [_squeeze(noise.signal)])
    value = (images, str(speech.source), str(noise.source))
    _PARTS[key] = _speech_parts(cond, images, _mono(speech.signal))
    _IMAGES[key] = value
    while len(_IMAGES) > _IMAGES_MAX:
        _PARTS.pop(_IMAGES.popitem(last=False)[0], None)
    return value


_PARTS: dict[tuple, Any] = {}  # (speech parts, acoustics columns) beside each cached group


def _speech_parts(cond: Condition, images, speech):
    """Speech parts and room acoustics of a group; None where reverberation is not studied
    (free field with a direct-path target: the thesis sweeps pay nothing for it)."""
    if cond.rt60_s == 0.0 and cond.reference == "direct":
        return None, {}
    from benchmarks.reverb_metrics import acoustics_columns
    from scenesim.reverb_parts import speech_parts

    parts = speech_parts(images, speech, early_window_s=cond.early_window_ms / 1000.0)
    return parts, acoustics_columns(images, parts, rt60_target_s=cond.rt60_s)


def group_parts(cond: Condition, data_dir: str | None):
    """``(SpeechParts or None, acoustics columns)`` of a condition's group (after :func:`render_group`)."""
    render_group(cond, data_dir)
    return _PARTS[(data_dir, cond.group_id)]


def _mono(x):
    import numpy as np

    x = np.asarray(x, dtype=np.float64)
    return x[0] if x.ndim == 2 else x


def _squeeze(x):
    import numpy as np

    x = np.asarray(x, dtype=np.float64)
    return x[0] if x.ndim == 2 and x.shape[0] == 1 else x


def build_enhancer(spec: EnhancerSpec, cond: Condition):
    """The enhancer of a spec, with the condition's array geometry when it needs one."""
    from enhancers.registry import make, with_geometry

    return with_geometry(make(spec.name, **spec.params), spacing_m=cond.spacing_m, c_mps=SPEED_OF_SOUND_MPS)


def run_unit(unit: UnitTask) -> list[list[dict[str, Any]]]:
    """The rows of every condition of a unit (one list per condition, in the unit's order)."""
    return [run_condition(task) for task in unit.conditions]


def run_condition(task: ConditionTask) -> list[dict[str, Any]]:
    """Compute the rows of one condition: render (or reuse) the scene, mix, measure every enhancer.

    Never raises for a problem with the condition: a failure to render or to build an
    enhancer gives rows with ``status='error'`` and the reason in ``error``.
    """
    from benchmarks.evaluate import evaluate_enhancer, input_metrics

    cond = task.condition
    worker = f"{socket.gethostname()}:{os.getpid()}"
    base = {
        **_condition_columns(cond),
        "scenesim_version": _scenesim_version(),
        "worker": worker,
    }
    rows: list[dict[str, Any]] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            t0 = time.perf_counter()
            images, speech_source, noise_source = render_group(cond, task.data_dir)
            parts, acoustics = group_parts(cond, task.data_dir)
            rendered = images.mix(cond.snr_db)
            if parts is not None and parts.reverberant and cond.reference != "direct":
                # Target = direct + early (the sweep's early window) for every intrusive metric.
                rendered = dataclasses.replace(rendered, reference=parts.target[:1].copy())
            base.update(speech_source=speech_source, noise_source=noise_source, **acoustics)
            base["render_s"] = time.perf_counter() - t0
            inputs = input_metrics(rendered, speech_parts=parts, reference=cond.reference)
        except Exception as exc:
            text = _exc_text(exc)
            return [{**base, "enhancer": s.name, "status": "error", "error": f"scene failed: {text}"} for s in task.enhancers]
        for spec in task.enhancers:
            row = dict(base)
            try:
                enhancer = build_enhancer(spec, cond)
                row["enhancer_spec"] = json.dumps(enhancer.spec, sort_keys=True, default=str)
                row["enhancer_version"] = str(enhancer.version)
                row.update(evaluate_enhancer(enhancer, rendered, input_metrics=inputs, speech_parts=parts))
            except Exception as exc:
                row.update(status="error", error=f"enhancer failed: {_exc_text(exc)}")
            row["enhancer"] = spec.name  # the sweep's name for it (e.g. "eb@1"), not the class's
            rows.append(row)
    notes = sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    if notes:
        for row in rows:
            row["warnings"] = "\n".join(notes)
    return rows


@functools.lru_cache(maxsize=1)
def _scenesim_version() -> str | None:
    return package_versions(("scenesim",))["scenesim"]


# -- the driver side ---------------------------------------------------------------------


def plan_conditions(
    sweep: Sweep,
    conditions: Sequence[Condition],
    done: set[tuple[str, str]],
    data_dir: str | None,
) -> list[ConditionTask]:
    """One task per condition that misses at least one enhancer's row, in sweep order."""
    specs = [
        EnhancerSpec(name, json.dumps(dict(sweep.enhancer_params.get(name, {})), sort_keys=True))
        for name in sweep.enhancers
    ]
    tasks = []
    for cond in conditions:
        missing = tuple(s for s in specs if (cond.id, s.name) not in done)
        if missing:
            tasks.append(ConditionTask(cond.to_json(), missing, data_dir))
    return tasks


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
    retry_errors: bool = False,
    report: bool = True,
    progress: bool = True,
    new_version: bool = False,
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
        Run only the first ``limit`` conditions of the sweep's order.
    seed : int, optional
        Offset the seeds axis (``seeds = [0]`` becomes ``[seed]``).
    retry_errors : bool
        Recompute rows stored with ``status='error'`` (by default they count as done).
    report : bool
        Write ``out_dir/report`` from every row in the store at the end.
    new_version : bool
        The store holds rows of another version of the sweep (any axis or fixed value,
        enhancer or parameter changed): move them to ``results_previous`` and start this
        version (without it such a run is refused, :mod:`benchmarks.versioning`).
    progress : bool
        Show a progress bar (only when stderr is a terminal).

    Returns
    -------
    RunSummary
        Counts, wall time and the report files.  Rows already in the store are not
        recomputed; rerunning after an interruption computes only what is missing.
    """
    check_choice("executor", executor, EXECUTORS)
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    if seed is not None:
        sweep = sweep.with_seed(seed)
    conditions = sweep.conditions()
    if limit is not None:
        if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
            raise ParameterError("limit", limit, "an integer >= 1")
        conditions = conditions[:limit]
    if data_dir is None:
        data_dir = os.environ.get("SCENESIM_DATA") or None
    data_dir = str(Path(data_dir).resolve()) if data_dir else None

    _check_data(conditions, data_dir)

    out_dir = Path(out_dir)
    t_start = time.perf_counter()
    with ResultStore.open(out_dir) as store:
        version = check_version(store, sweep, out_dir=out_dir, new_version=new_version)
        done = store.done_keys(include_errors=not retry_errors)
        tasks = plan_conditions(sweep, conditions, done, data_dir)
        _warn_changed_data(store, data_dir, n_kept=len(conditions) - len(tasks))
        run_id = store.start_run(
            sweep=sweep.name,
            source=sweep.source,
            config_toml=sweep.text,
            options={"limit": limit, "seed": seed, "retry_errors": retry_errors, "enhancers": sweep.enhancers},
            executor=executor,
            workers=workers or (None if scheduler else os.cpu_count()),
            scheduler=scheduler,
            data_dir=data_dir,
        )
        n_rows = n_errors = 0
        notes: dict[str, None] = {}
        status = "failed"
        try:
            if tasks:
                ex = make_executor(executor, workers=workers, scheduler=scheduler, preload=WORKER_PRELOAD)
                try:
                    units = plan_units(tasks, workers=ex.workers or 1)
                    with _progress(len(tasks), sweep.name, enabled=progress, workers=ex.workers) as bar:
                        for unit, outcome in ex.run(run_unit, units):
                            for rows in _rows_of(unit, outcome, run_id, version):
                                # one transaction per condition: a kill never leaves half of one
                                n_rows += store.write_rows(rows)
                                n_errors += sum(r.get("status") != "ok" for r in rows)
                                for r in rows:
                                    for note in (r.get("warnings") or "").split("\n"):
                                        if note:
                                            notes[note] = None
                            bar.update(len(unit))
                            if n_errors:
                                bar.set_postfix(errors=n_errors, refresh=False)
                finally:
                    ex.close()
            status = "finished"
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM under signals.sigterm_as_interrupt
            status = "interrupted"
            raise interrupted(exc, n_written=n_rows, n_stored=len(store.done_keys()), store_path=store.path) from None
        finally:
            store.finish_run(run_id, status=status, n_rows_written=n_rows, n_errors=n_errors)

        report_files: tuple[Path, ...] = ()
        report_error = None
        if report:
            try:
                report_files = tuple(write_store_report(out_dir, store=store))
            except Exception as exc:  # the rows are safe in the store; say so instead of crashing
                report_error = _exc_text(exc)
    return RunSummary(
        out_dir=out_dir,
        store_path=store.path,
        run_id=run_id,
        n_conditions=len(conditions),
        n_computed=len(tasks),
        n_skipped=len(conditions) - len(tasks),
        n_rows=n_rows,
        n_errors=n_errors,
        wall_s=time.perf_counter() - t_start,
        report_files=report_files,
        report_error=report_error,
        warnings=tuple(notes),
    )


def _check_data(conditions: Sequence[Condition], data_dir: str | None) -> None:
    """Fail before starting (not in every worker) on a bad data directory or unknown noise type."""
    from data_recipes import open_data

    for fs in sorted({c.fs for c in conditions}):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # workers report fallbacks in the rows
            ds = open_data(data_dir, fs=fs)
        available = set(ds.noise_types())
        for noise in sorted({c.noise for c in conditions} - available):
            raise ConfigError(
                f"noise type {noise!r} is neither in the data directory ({ds.description}) nor "
                f"synthesizable; available: {', '.join(sorted(available))}"
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


def _condition_columns(cond: Condition) -> dict[str, Any]:
    return {
        "condition_id": cond.id,
        "snr_in_db": cond.snr_db,
        **{c: getattr(cond, c) for c in _CONDITION_COLUMNS},
        **sensor_columns(cond),
        "group_id": cond.group_id,
        "condition_json": cond.to_json(),
    }


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


def write_store_report(out_dir: str | Path, *, store: ResultStore | None = None, listen=None) -> list[Path]:
    """Write ``out_dir/report`` (Markdown, CSV, PNG, index.html) from every row of ``out_dir/results.sqlite``.

    ``listen``: a :class:`benchmarks.listening.ListenOptions` (which conditions get audio).
    """
    from benchmarks.report import write_report

    own = store is None
    if own:
        store = ResultStore.open(out_dir, readonly=True)
    try:
        rows = store.rows()
        runs = store.runs()
        version = store.get_meta("sweep_version")
    finally:
        if own:
            store.close()
    meta = report_meta(runs, Path(out_dir) / "results.sqlite")
    if version is not None:
        # Never average rows of two sweep versions: the store's current version only.
        other = sum(r.get("sweep_version") not in (None, version) for r in rows)
        rows = [r for r in rows if r.get("sweep_version") in (None, version)]
        meta["sweep version"] = version + (f" ({other} rows of other versions not shown)" if other else "")
    return list(write_report(rows, Path(out_dir), meta=meta, listen=listen))


def report_meta(runs: Sequence[Mapping[str, Any]], store_path: Path) -> dict[str, str]:
    """One-line facts for the report's header: store, sweeps, runs, data, versions."""
    meta = {"store": str(store_path)}
    if not runs:
        return meta
    last = runs[-1]
    meta["sweep"] = ", ".join(dict.fromkeys(str(r["sweep"]) for r in runs))
    workers = f", {last['workers']} workers" if last.get("workers") else ""
    where = f" at {last['scheduler']}" if last.get("scheduler") else ""
    meta["runs"] = (
        f"{len(runs)}; last: {last['executor']}{where}{workers}, on {last['hostname']}, "
        f"{last['started_at']} -> {last['finished_at'] or '(unfinished)'}, {last['status']}"
    )
    meta["data"] = str(last.get("data_dir") or "built-in (artificial voice + synthesized noise)")
    try:
        versions = json.loads(last.get("versions_json") or "{}")
    except ValueError:
        versions = {}
    meta["versions"] = ", ".join(f"{k} {v}" for k, v in versions.items() if v)
    return meta


__all__ = [
    "EnhancerSpec",
    "RunSummary",
    "ConditionTask",
    "UnitTask",
    "build_enhancer",
    "build_scene",
    "plan_conditions",
    "plan_units",
    "run_condition",
    "render_group",
    "run_sweep",
    "run_unit",
    "write_store_report",
]
