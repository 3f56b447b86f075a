"""Sweep versions: a store never mixes rows of two versions of a sweep silently (issue 8, section 4).

A sweep's *version* is a hash of everything that decides its numbers: every axis and fixed
value (durations, geometry, sensors, ...), the enhancers and their parameters, the rooms, and
the definitions of fixed result columns that changed meaning (:data:`DEFINITIONS`: when one
changes, every sweep's version changes, so old rows are never averaged with new ones).
Not part of it: the sweep's name and description, ``--limit`` (running a prefix is how a
sweep resumes) and ``--seed`` (more seeds of the same sweep are more samples of it).

The store keeps the version its rows belong to (table ``meta``, and every row's
``sweep_version``).  Running a changed sweep into a store that holds rows of another
version raises :class:`SweepVersionError` with one line saying what changed and how to go
on: a new ``--out``, or ``--new-version``, which moves the old rows to the table
``results_previous`` (nothing is deleted) and starts the new version.

Example
-------
>>> from benchmarks.run.sweep import load_sweep
>>> a = sweep_config(load_sweep("smoke"))
>>> b = dict(a, axes=dict(a["axes"], duration_s=[3.0]))
>>> describe_changes(a, b)
'duration_s 2.0 -> 3.0'
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from benchmarks.metrics.g160 import G160_DEFINITION
from benchmarks.run.sweep import Sweep, parse_sweep
from scenesim.errors import ConfigError

#: Definitions of fixed columns that changed meaning since the first release, by their version
#: (``g160``: :data:`benchmarks.metrics.g160.G160_DEFINITION`).
DEFINITIONS = {"g160": G160_DEFINITION}

#: ``meta`` keys of the store.
META_VERSION = "sweep_version"
META_CONFIG = "sweep_config"


class SweepVersionError(ConfigError):
    """The store holds rows of another version of the sweep."""


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)  # 5 and 5.0 are the same setting
    return value


def sweep_config(sweep: Sweep) -> dict[str, Any]:
    """The parts of a sweep that decide its numbers, as plain JSON types."""
    axes = {k: _plain(v) for k, v in sweep.axes.items() if k != "seed"}
    return {
        "axes": axes,
        "seeds": [int(s) for s in sweep.axes["seed"]],
        "enhancers": list(sweep.enhancers),
        "enhancer_params": _plain({k: dict(v) for k, v in sweep.enhancer_params.items()}),
        "rooms": {
            name: {"dims_m": _plain(r.dims_m), "pair_center_m": _plain(r.pair_center_m),
                   "axis_azimuth_deg": float(r.axis_azimuth_deg)}
            for name, r in sorted(sweep.rooms.items())
        },  # fmt: skip
        "definitions": dict(DEFINITIONS),
        # the enhancer each [parameter_sets] system builds (its parameters are in enhancer_params);
        # absent without such systems, so the versions of other sweeps stay as they were
        **({"parameter_sets": {n: sweep.registered_name(n) for n in sorted(sweep.parameter_sets)}}
           if sweep.parameter_sets else {}),
    }


def config_version(config: Mapping[str, Any]) -> str:
    """12 hex digits of SHA-256 over the canonical JSON of a :func:`sweep_config`.

    The order of ``enhancers`` is not content (each row is one enhancer): it is sorted first,
    so stores written before this rule keep their version when their list was already sorted,
    and a reordered list is the same version.
    """
    config = {**config, "enhancers": sorted(config.get("enhancers", []))}
    text = json.dumps(config, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def _show(value: Any) -> str:
    if isinstance(value, list) and len(value) == 1:
        value = value[0]
    if isinstance(value, float):
        return f"{value:g}" if value != int(value) else f"{value:.1f}"
    return json.dumps(value) if not isinstance(value, str) else value


def describe_changes(old: Mapping[str, Any], new: Mapping[str, Any], *, limit: int = 4) -> str:
    """One line naming what differs between two sweep configs (``key old -> new``, ...)."""
    parts: list[str] = []
    keys = list(dict.fromkeys([*old.get("axes", {}), *new.get("axes", {})]))
    for key in keys:
        a, b = old.get("axes", {}).get(key), new.get("axes", {}).get(key)
        if a != b:
            parts.append(f"{key} {_show(a)} -> {_show(b)}")
    for key in ("seeds", "enhancers", "rooms", "definitions", "parameter_sets"):
        if old.get(key) != new.get(key):
            parts.append(f"{key} {_show(old.get(key))} -> {_show(new.get(key))}")
    po, pn = old.get("enhancer_params", {}), new.get("enhancer_params", {})
    for name in sorted(set(po) | set(pn)):
        if po.get(name) != pn.get(name):
            parts.append(f"enhancer_params.{name} {_show(po.get(name, {}))} -> {_show(pn.get(name, {}))}")
    if not parts:
        return "no visible change"
    more = f" and {len(parts) - limit} more" if len(parts) > limit else ""
    return "; ".join(parts[:limit]) + more


def stored_config(store) -> dict[str, Any] | None:
    """The config of the rows in ``store``: its ``meta`` entry, else (stores written before
    versions existed) parsed from the last run's sweep text; None if neither is known."""
    text = store.get_meta(META_CONFIG)
    if text:
        return json.loads(text)
    runs = store.runs()
    if runs and runs[-1].get("config_toml"):
        try:
            return sweep_config(parse_sweep(runs[-1]["config_toml"]))
        except Exception:  # an unreadable old config: no version to compare with
            return None
    return None


def check_version(store, sweep: Sweep, *, out_dir, new_version: bool = False) -> str:
    """Make ``store`` hold ``sweep``'s version; returns it.

    Raises :class:`SweepVersionError` when the store holds rows of another version, unless
    ``new_version``: then those rows move to ``results_previous`` first.
    """
    config = sweep_config(sweep)
    version = config_version(config)
    if store.count():
        old = stored_config(store)
        if old is not None and config_version(old) != version:
            if not new_version:
                runs = store.runs()
                stored_name = runs[-1].get("sweep") if runs else None
                what = (f"another version of sweep {sweep.name!r}" if stored_name in (None, sweep.name)
                        else f"sweep {stored_name!r}, not {sweep.name!r}")
                raise SweepVersionError(
                    f"{out_dir} holds {store.count()} rows of {what} ({describe_changes(old, config)}); "
                    "use a new --out, or --new-version to move those rows to table results_previous "
                    "and start over"
                )
            store.archive_rows()
    store.set_meta(META_CONFIG, json.dumps(config, sort_keys=True))
    store.set_meta(META_VERSION, version)
    return version
