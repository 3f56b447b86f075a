"""Named parameter sets (``params.toml``): tuned parameters with where they came from.

A parameter set is a TOML file::

    [parameter_set]
    name = "eb-robust-tuned"        # the name register_tuned gives it by default
    enhancer = "eb-robust"          # the registered enhancer whose Params these are
    unset = []                      # fields set to None (TOML has no null)

    [params]
    mu = 0.05

    [provenance]                    # objective, constraints, trials, split, seeds, data, versions...
    split = "dev"
    test_evaluations = 1

:func:`load_parameter_set` reads it back into equal values; ``enhancers.make(ps.enhancer,
**ps.params)`` builds the system, and :func:`register_tuned` registers it under a new name with
the provenance in its registry entry (``enhancers.core.registry.get_spec(name).provenance``).
A registration lives in the process that made it (a notebook, ``enhancers.make``, a
``--workers 1`` run); pool workers start from a fork server that never saw it, so for
``scenesim bench run`` name the file in the sweep's ``[parameter_sets]`` table
(``eb-robust-tuned = "tune-eb/params.toml"``, the name then listed in ``axes.enhancers``).
Both ways record the provenance with the run, and the report says on top when a tuned system
is evaluated on the material it was tuned on (:mod:`benchmarks.tune.overlap`).  Parameters
copied by hand into ``[enhancer_params]`` carry no provenance.

The reader (:class:`ParameterSet`, :func:`load_parameter_set`) lives in
:mod:`benchmarks.run.parameter_sets`, below the runner that reads a sweep's parameter sets.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from benchmarks.run.parameter_sets import ParameterSet, load_parameter_set, origin
from scenesim.errors import ConfigError

__all__ = ["PARAMS_FILE", "ParameterSet", "data_fingerprint", "load_parameter_set", "register_tuned",
           "save_parameter_set", "versions"]

PARAMS_FILE = "params.toml"


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else ("inf" if value > 0 else "-inf"))
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ConfigError(f"cannot write {value!r} ({type(value).__name__}) to a parameter set")


def _toml_table(name: str, values: Mapping[str, Any]) -> list[str]:
    lines = [f"[{name}]"]
    subtables = []
    for key, value in values.items():
        if isinstance(value, Mapping):
            subtables.append((f"{name}.{key}", value))
        elif value is not None:
            lines.append(f"{json.dumps(str(key))} = {_toml_value(value)}")
    for sub in subtables:
        lines += ["", *_toml_table(*sub)]
    return lines


def save_parameter_set(path: str | Path, pset: ParameterSet) -> Path:
    """Write ``pset`` to ``path`` as TOML (None-valued provenance entries are left out)."""
    unset = sorted(k for k, v in pset.params.items() if v is None)
    head = {"name": pset.name, "enhancer": pset.enhancer, "unset": unset}
    lines = ["# A scenesim parameter set; load with benchmarks.tune.load_parameter_set(path).", ""]
    lines += _toml_table("parameter_set", head) + [""]
    lines += _toml_table("params", {k: v for k, v in pset.params.items() if v is not None}) + [""]
    lines += _toml_table("provenance", pset.provenance)
    path = Path(path)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def register_tuned(name: str, path: str | Path) -> ParameterSet:
    """Register the parameter set at ``path`` as enhancer ``name`` (its provenance in the entry).

    ``enhancers.make(name)`` then builds the tuned system, and
    ``enhancers.core.registry.get_spec(name).provenance`` says what it was tuned on.
    """
    from enhancers.core.registry import get_spec, register

    pset = load_parameter_set(path)
    base = get_spec(pset.enhancer)
    spec = register(name, base.load(), **{**base.default_params, **pset.params})
    spec.provenance = origin(path, pset)
    return pset


def data_fingerprint(data_dir: str | Path | None) -> dict[str, str]:
    """``{"data": path or "built-in", "data_sha256": ...}``: a hash of the relative names and
    sizes of every file under the data directory (the built-in data is fixed by the code version)."""
    if data_dir is None:
        return {"data": "built-in", "data_sha256": ""}
    root = Path(data_dir).resolve()
    h = hashlib.sha256()
    for f in sorted(p for p in root.rglob("*") if p.is_file()):
        h.update(f"{f.relative_to(root).as_posix()}\0{f.stat().st_size}\n".encode())
    return {"data": str(root), "data_sha256": h.hexdigest()}


def versions() -> dict[str, str]:
    """Versions of scenesim, numpy and optuna (recorded with every parameter set)."""
    from importlib import metadata

    out = {}
    for dist in ("scenesim", "numpy", "optuna"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out
