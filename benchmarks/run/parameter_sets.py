"""Reading a named parameter set (``params.toml``) and the tuning provenance a run records.

A parameter set is written by ``scenesim tune`` (:mod:`benchmarks.tune.paramset` documents the
file and writes it); it is read here, below the runner, because a sweep may run one as a system
of its own (``[parameter_sets]``, :mod:`benchmarks.run.sweep`).  :func:`tuned_provenance` gathers
what every tuned system of a sweep was tuned on -- from the sweep's parameter sets and from
registry entries made by :func:`benchmarks.tune.register_tuned` -- and the runner keeps it with
the run (``runs.options_json["tuned"]``), so a report can say when it evaluates a system on the
material it was tuned on (:mod:`benchmarks.tune.overlap`).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenesim.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib


@dataclass(frozen=True)
class ParameterSet:
    """A named set of an enhancer's parameters and its provenance (what it was tuned on)."""

    name: str
    enhancer: str
    params: Mapping[str, Any]
    provenance: Mapping[str, Any] = field(default_factory=dict)


def load_parameter_set(path: str | Path) -> ParameterSet:
    """Read a parameter set written by :func:`benchmarks.tune.save_parameter_set` (``scenesim tune``'s ``params.toml``).

    Lists come back as lists (``Params.from_dict`` turns them into tuples where a field is one);
    fields listed in ``unset`` come back as None.  Errors name the file.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text("utf-8"))
    except OSError as exc:
        raise ConfigError(f"cannot read parameter set {path}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not a parameter set (invalid TOML: {exc})") from None
    head = data.get("parameter_set")
    if not isinstance(head, dict) or not isinstance(head.get("enhancer"), str):
        raise ConfigError(f"{path}: not a parameter set (expected [parameter_set] with enhancer = \"NAME\")")
    params = dict(data.get("params", {}))
    params.update(dict.fromkeys(head.get("unset", ()), None))
    return ParameterSet(str(head.get("name", path.stem)), head["enhancer"], params, dict(data.get("provenance", {})))


def origin(path: str | Path, pset: ParameterSet) -> dict[str, Any]:
    """The provenance a system built from ``pset`` (read from ``path``) carries: the file, the
    enhancer and everything the file's ``[provenance]`` says."""
    return {"parameter_set": str(Path(path).resolve()), "enhancer": pset.enhancer, **pset.provenance}


def tuned_provenance(sweep) -> dict[str, dict[str, Any]]:
    """``{system: provenance}`` for the systems of ``sweep`` that were tuned: those of its
    ``[parameter_sets]`` and registry entries with a provenance (``register_tuned``); empty
    when none was.  Recorded with each run (:func:`benchmarks.run.runner.run_sweep`)."""
    from enhancers.core.registry import get_spec

    out: dict[str, dict[str, Any]] = {}
    for name in sweep.enhancers:
        if name in sweep.parameter_sets:
            path, pset = sweep.parameter_sets[name]
            out[name] = origin(path, pset)
            continue
        provenance = get_spec(name).provenance
        if provenance:
            out[name] = dict(provenance)
    return out
