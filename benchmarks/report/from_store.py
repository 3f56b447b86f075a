"""Report glue: from a results store on disk to ``DIR/report`` (the report itself is
:mod:`benchmarks.report.core`; this module only reads the store and its run metadata).

What the store's ``runs`` table says about the rows is said on the page, never averaged in
silently (:func:`coverage_banner`): a run limited to ``N of M`` conditions of its sweep, rows of
a run that stopped (interrupted, failed) or never finished, and rows of other sweep versions
(left out and counted), and the rows of a tuned system that use the material it was tuned on
(:mod:`benchmarks.tune.overlap`: in-sample numbers, named per system, counted in ``in_sample.csv``).
The sweep's ``[sweep] ranking`` rule is read from the last run's TOML.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.store.sqlite import ResultStore
from benchmarks.tune.overlap import overlap_banner, store_overlaps, write_overlap_csv


def write_store_report(out_dir: str | Path, *, store: ResultStore | None = None, listen=None) -> list[Path]:
    """Write ``out_dir/report`` (Markdown, CSV, PNG, index.html) from every row of ``out_dir/results.sqlite``.

    ``listen``: a :class:`benchmarks.report.listening.ListenOptions` (which conditions get audio).
    """
    from benchmarks.report.core import write_report

    own = store is None
    if own:
        store = ResultStore.open(out_dir, readonly=True)
    try:
        rows = store.rows()
        runs = store.runs()
        version = store.get_meta("sweep_version")
        config = store.get_meta("sweep_config")
    finally:
        if own:
            store.close()
    meta = report_meta(runs, Path(out_dir) / "results.sqlite")
    banner: list[str] = []
    if version is not None:
        # Never average rows of two sweep versions: the store's current version only.
        other = sum(r.get("sweep_version") not in (None, version) for r in rows)
        rows = [r for r in rows if r.get("sweep_version") in (None, version)]
        meta["sweep version"] = version + (f" ({other} rows of other versions not shown)" if other else "")
        if other:
            banner.append(f"{other} rows of other sweep versions are in the store and not shown.")
    meta["column definitions"] = definitions_text(config)
    sweep = last_sweep(runs)
    banner += coverage_banner(rows, runs, sweep)
    overlaps = store_overlaps(rows, runs)
    banner += overlap_banner(overlaps)
    ranking = sweep.ranking if sweep is not None else ()
    paths = list(write_report(rows, Path(out_dir), meta=meta, listen=listen, ranking=ranking, banner=banner))
    if overlaps:  # the tuned systems' material and their in-sample counts, beside the tables
        paths.append(write_overlap_csv(paths[0].parent / "in_sample.csv", overlaps))
    return paths


def definitions_text(config_json: str | None) -> str:
    """The definitions of changed fixed columns the rows were computed with, in words.

    >>> definitions_text('{"definitions": {"g160": 2}}').startswith("g160 v2")
    True
    >>> definitions_text(None).startswith("g160 v1")
    True
    """
    try:
        defs = json.loads(config_json or "{}").get("definitions") or {}
    except (ValueError, AttributeError):
        defs = {}
    if defs.get("g160", 1) >= 2:
        return ("g160 v2: the G.160 columns are the recommendation's estimate (mixture and output) for every "
                "system with P.56 activity; g160_*_exact_db the exact replayed values")
    return ("g160 v1 (rows from before issue 32): G.160 from the exact parts for white boxes and the estimate "
            "for black boxes, level-gated activity -- not comparable with v2 rows; run with --new-version to "
            "recompute")


def last_sweep(runs: Sequence[Mapping[str, Any]]):
    """The last run's sweep with its ``--seeds`` / ``--seed`` / ``--split`` applied (None when unreadable)."""
    from benchmarks.run.sweep import parse_sweep
    from scenesim.errors import ScenesimError

    if not runs or not runs[-1].get("config_toml"):
        return None
    opts = _options(runs[-1])
    try:
        sweep = parse_sweep(runs[-1]["config_toml"], source=str(runs[-1].get("source")))
        if opts.get("split"):
            sweep = sweep.with_split(opts["split"])
        if opts.get("seeds"):
            sweep = sweep.with_seeds(int(opts["seeds"]))
        if opts.get("seed"):
            sweep = sweep.with_seed(int(opts["seed"]))
    except (ScenesimError, ValueError, TypeError):
        return None
    return sweep


def _options(run: Mapping[str, Any]) -> dict[str, Any]:
    try:
        return json.loads(run.get("options_json") or "{}")
    except ValueError:
        return {}


def coverage_banner(rows: Sequence[Mapping[str, Any]], runs: Sequence[Mapping[str, Any]], sweep) -> list[str]:
    """Warnings for the top of the page: ``N of M conditions`` when the rows cover part of the
    sweep (with the ``--limit`` that made it so), and the rows written by runs that did not finish.

    >>> coverage_banner([{"condition_id": "a", "run_id": "r1"}],
    ...                 [{"run_id": "r1", "status": "interrupted", "started_at": "t0"}], None)
    ['1 of these rows were written by run r1 (started t0), which ended interrupted: they are included.']
    """
    out = []
    if sweep is not None:
        expected = {c.id for c in sweep.conditions()}
        have = {r.get("condition_id") for r in rows} & expected
        if len(have) < len(expected):
            limit = _options(runs[-1]).get("limit") if runs else None
            why = f" (the last run was limited: --limit {limit})" if limit else ""
            out.append(f"Partial run: {len(have)} of {len(expected)} conditions of sweep '{sweep.name}' are in "
                       f"this report{why}; points and intervals hold fewer seeds and conditions than the sweep "
                       "(every caption gives its n).")  # fmt: skip
    by_run: dict[Any, int] = {}
    for r in rows:
        by_run[r.get("run_id")] = by_run.get(r.get("run_id"), 0) + 1
    for run in runs:
        n = by_run.get(run.get("run_id"), 0)
        if n and run.get("status") != "finished":
            ended = f"ended {run['status']}" if run.get("status") else "never finished"
            out.append(f"{n} of these rows were written by run {run['run_id']} (started {run.get('started_at')}), "
                       f"which {ended}: they are included.")  # fmt: skip
    return out


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
