"""Report glue: from a results store on disk to ``DIR/report`` (the report itself is
:mod:`benchmarks.report.core`; this module only reads the store and its run metadata)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.store.sqlite import ResultStore


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
