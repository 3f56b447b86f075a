"""The conditions the report's listening page plays, and their audio saved during the sweep.

:func:`pick_conditions` is a function of the set of conditions only (the values of their
swept axes, their seeds and ids), never of the order rows were stored in, so the runner knows
the choice before any condition runs (:func:`listen_ids` over the sweep's conditions) and the
report, choosing from the stored rows, finds the same conditions.  Their workers return the
clean reference and the mixture at mic 0 and each system's first output channel with the rows
(:data:`CLIPS_KEY`); the driver saves them as ``DIR/listen_audio/<condition_id>.npz``
(:func:`save_clips`, float32) and the report only loudness-matches and encodes them
(:func:`load_clips`; it re-renders a condition whose clips are missing or not those of the
stored rows).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # the sweep module pulls in the scene renderer (scipy.signal, ~1.3 s): a report needs none of it
    from benchmarks.run.sweep import Condition

#: The swept axes the picker spreads over (those with more than one value; not drawn per seed).
LISTEN_AXES = ("rt60_s", "distance_m", "noise", "snr_in_db")
#: Conditions given audio by default (the runner saves this many).
DEFAULT_LISTEN_COUNT = 6
#: Folder of the store directory the saved clips go to.
CLIPS_DIRNAME = "listen_audio"
#: Key of a worker's first row of a condition that carries its clips to the driver (never stored).
CLIPS_KEY = "_listen_clips"


def _spread(n: int) -> list[int]:
    """Indices 0..n-1 in the order lowest, middle, highest, then the rest (n >= 1)."""
    first = [0, (n - 1) // 2, n - 1]
    order = list(dict.fromkeys(first))
    return order + [i for i in range(n) if i not in order]


def _values(records: Sequence[Mapping[str, Any]], axis: str) -> list:
    vals = {r.get(axis) for r in records if r.get(axis) is not None}
    return sorted(vals, key=lambda v: (0, v, "") if isinstance(v, (int, float)) else (1, 0.0, str(v)))


def _drawn(record: Mapping[str, Any], axis: str) -> bool:
    """Whether ``axis`` was drawn per seed (the condition holds its range, not a swept value)."""
    from benchmarks.run.sweep import _RANGE_KEYS  # lazy: see the imports

    rng = _RANGE_KEYS.get(axis)
    return rng is not None and f'"{rng}"' in str(record.get("condition_json") or "")


def pick_conditions(records: Sequence[Mapping[str, Any]], *, count: int) -> list[str]:
    """``count`` condition ids spread over :data:`LISTEN_AXES` (RT60, talker distance, noise,
    input SNR) among ``records`` (mappings with ``condition_id``, ``seed``,
    ``condition_json`` and those columns, e.g. results rows).

    Every value of every axis is heard before any is heard twice
    (:func:`benchmarks.run.sweep.stratified`); among equally new picks the extremes of an
    axis come first (lowest, middle, highest).  For a combination of axis values the
    condition with the lowest seed, then the smallest id, is used: the choice depends on the
    set of records, not their order.  Values drawn per seed are not an axis.

    >>> recs = [{"condition_id": f"{n}{s}", "noise": n, "snr_in_db": s, "seed": 0}
    ...         for n in ("wind", "babble") for s in (0, 5, 10)]
    >>> pick_conditions(recs, count=4)
    ['babble0', 'wind0', 'babble10', 'wind5']
    >>> pick_conditions(recs[::-1], count=4) == pick_conditions(recs, count=4)
    True
    >>> pick_conditions(recs, count=0)
    []
    """
    if count <= 0:  # no listening page (``--listen-count 0``): nothing to pick, nothing to import
        return []
    axes = [a for a in LISTEN_AXES if len(_values(records, a)) > 1 and not any(_drawn(r, a) for r in records)]
    best: dict[tuple, tuple[int, str]] = {}
    for r in records:
        key = tuple(r.get(a) for a in axes)
        cand = (int(r.get("seed") or 0), str(r["condition_id"]))
        if key not in best or cand < best[key]:
            best[key] = cand
    # Extremes first: each axis value's place in the lowest/middle/highest order.
    rank = {}
    for a in axes:
        vals = _values(records, a)
        rank[a] = {v: _spread(len(vals)).index(i) for i, v in enumerate(vals)}
    keys = sorted(best, key=lambda k: (sum(rank[a][v] for a, v in zip(axes, k)), best[k]))
    from benchmarks.run.sweep import stratified  # lazy: see the imports

    picked = stratified(keys, count, axes, value=lambda k, a: k[axes.index(a)])
    picked.sort(key=keys.index)
    return [best[k][1] for k in picked]


def condition_record(cond: Condition) -> dict[str, Any]:
    """The columns :func:`pick_conditions` reads, as a results row of ``cond`` holds them."""
    return {"condition_id": cond.id, "condition_json": cond.to_json(), "seed": cond.seed, "noise": cond.noise,
            "snr_in_db": cond.snr_db, "rt60_s": cond.rt60_s, "distance_m": cond.distance_m}  # fmt: skip


def listen_ids(conditions: Sequence[Condition], count: int = DEFAULT_LISTEN_COUNT) -> list[str]:
    """The ids of the conditions the listening page will play, from a sweep's conditions.

    >>> from benchmarks.run.sweep import load_sweep
    >>> conds = load_sweep("smoke").conditions()
    >>> sorted((c.noise, c.snr_db) for c in conds if c.id in listen_ids(conds, 2))
    [('babble', 0.0), ('wind', 10.0)]
    """
    return pick_conditions([condition_record(c) for c in conditions], count=count)


def clips_path(out_dir: str | Path, condition_id: str) -> Path:
    """Where the clips of a condition are saved under a store directory."""
    return Path(out_dir) / CLIPS_DIRNAME / f"{re.sub(r'[^A-Za-z0-9_.-]+', '_', condition_id)}.npz"


def worker_clips(fs: int, reference, mixture, outputs: Mapping[str, Any]) -> dict[str, Any]:
    """What a worker attaches to a condition's first row under :data:`CLIPS_KEY` (mono float32)."""

    def mono(x):
        return np.asarray(x, dtype=np.float32).reshape(-1, np.shape(x)[-1])[0]

    return {"fs": int(fs), "reference": mono(reference), "mixture": mono(mixture),
            "outputs": {name: mono(y) for name, y in outputs.items()}}  # fmt: skip


def save_clips(out_dir: str | Path, rows: Sequence[Mapping[str, Any]], clips: Mapping[str, Any]) -> Path:
    """Save a condition's clips beside what identifies them in its stored ``rows`` (run, scene
    data, each system's spec); returns the file.  Written to a temporary name, then renamed."""
    first = rows[0]
    ok = {str(r["enhancer"]): r for r in rows if r.get("status") == "ok" and r["enhancer"] in clips["outputs"]}
    meta = {"fs": clips["fs"], "run_id": first.get("run_id"), "condition_json": first.get("condition_json"),
            "speech_source": first.get("speech_source"), "noise_source": first.get("noise_source"),
            "enhancers": [[name, r.get("enhancer_spec")] for name, r in ok.items()]}  # fmt: skip
    path = clips_path(out_dir, str(first["condition_id"]))
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {"reference": clips["reference"], "mixture": clips["mixture"]}
    arrays.update({f"output_{i}": clips["outputs"][name] for i, name in enumerate(ok)})
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays)
    tmp.replace(path)
    return path


def load_clips(out_dir: str | Path, rows: Mapping[str, Mapping[str, Any]]) -> tuple[dict[str, np.ndarray], int] | None:
    """``({"reference", "mixture", *systems}: mono signal}, fs)`` saved for the stored ``rows``
    (enhancer name -> row of one condition), or None when there are none or they are not those
    rows' (another run, scene data or system spec, or a system missing)."""
    first = next(iter(rows.values()))
    path = clips_path(out_dir, str(first["condition_id"]))
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            meta = json.loads(str(data["meta"]))
            specs = dict(meta["enhancers"])  # name -> spec; output_<i> is the i-th name
            names = [name for name, _ in meta["enhancers"]]
            arrays = {k: data[k] for k in data.files if k != "meta"}
    except (OSError, ValueError, KeyError):
        return None
    same = all(meta.get(k) == first.get(k) for k in ("run_id", "condition_json", "speech_source", "noise_source"))
    if not same or any(specs.get(n) != r.get("enhancer_spec") or r.get("run_id") != meta["run_id"]
                       for n, r in rows.items()):  # fmt: skip
        return None
    signals = {"reference": arrays["reference"], "mixture": arrays["mixture"]}
    signals.update({name: arrays[f"output_{names.index(name)}"] for name in rows})
    return signals, int(meta["fs"])


__all__ = [
    "CLIPS_DIRNAME",
    "CLIPS_KEY",
    "DEFAULT_LISTEN_COUNT",
    "LISTEN_AXES",
    "clips_path",
    "condition_record",
    "listen_ids",
    "load_clips",
    "pick_conditions",
    "save_clips",
    "worker_clips",
]
