"""In-sample rows: which rows of a report use the material a tuned system was tuned on.

A system built from a parameter set (``scenesim tune``'s ``params.toml``, run through a sweep's
``[parameter_sets]`` or :func:`benchmarks.tune.register_tuned`) carries its provenance, and each
run keeps it (``runs.options_json["tuned"]``, :mod:`benchmarks.run.parameter_sets`).  A row of
such a system is *in-sample* when any of these holds:

* **split** -- it drew from the data the system was tuned on (the same data directory, or both
  built in) and from the tuning split, or either of the two splits is ``all`` (``all`` holds
  every piece of material, dev and test alike); those of them on the tuning seeds are counted
  apart, being the tuning conditions themselves;
* **files** -- one of its speech or noise files (or a time segment of one) is among, or overlaps
  a segment of, the files the tuning drew (provenance ``dev_files``, written by ``scenesim tune``
  since this module exists; older parameter sets are judged by split, seeds and data only).

A file label is a row's ``speech_files`` / ``noise_files`` entry (:attr:`data_recipes.source.Clip.files`):
a path, a path with the segment ``[a:b]`` a split cut from it, and ``@offset`` where a noise clip
started; a generator label (``artificial-voice:...:seed=S``, ``synthetic:wind:seed=S``) is its
own file, the seed being the split's generator seed.  The offset is not material: a clip loops
inside its file or segment, so two labels of one file share material when their segments meet.
A synthesizer's recipe parts (``wind:gusts0.5Hz``, ``factory:mains50Hz``: no absolute path
(the runner resolves data directories), segment or seed) are settings shared by every clip of the type, not material, and are left out; so is a
multichannel clip's ``ch<k>:`` prefix.

>>> shares(material("/d/noise/a.wav[0:900]@17"), material("/d/noise/a.wav[900:1000]"))
False
>>> shares(material("/d/noise/a.wav"), material("/d/noise/a.wav[900:1000]@3"))
True
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

_LABEL = re.compile(r"^(?:ch\d+:)?(?P<file>.*?)(?:\[(?P<a>\d+):(?P<b>\d+)\])?(?:@\d+)?$")

#: Columns of ``in_sample.csv`` (one line per tuned system of a report).
CSV_COLUMNS = ("system", "parameter_set", "tuned_split", "tuned_seeds", "tuned_data", "rows", "in_sample_rows",
               "on_tuning_split", "on_tuning_seeds", "sharing_files")


def material(label: str) -> tuple[str, int | None, int | None]:
    """``(file, start, stop)`` of a file label; ``start, stop`` None for a whole file.

    >>> material("ch1:/d/noise/wind.wav[0:480000]@1234")
    ('/d/noise/wind.wav', 0, 480000)
    >>> material("synthetic:wind:seed=7")
    ('synthetic:wind:seed=7', None, None)
    """
    m = _LABEL.match(label)
    a, b = m.group("a"), m.group("b")
    return m.group("file"), (int(a) if a else None), (int(b) if b else None)


def is_material(m: tuple[str, int | None, int | None]) -> bool:
    """True for a file, a segment or a seeded generator; False for a synthesizer's recipe part.

    >>> [is_material(material(x)) for x in ("wind:flat<100Hz,f^-7/3 above", "synthetic:wind:seed=7", "/d/a.wav")]
    [False, True, True]
    """
    return m[1] is not None or "seed=" in m[0] or PurePosixPath(m[0]).is_absolute() or PureWindowsPath(m[0]).is_absolute()


def shares(x: tuple[str, int | None, int | None], y: tuple[str, int | None, int | None]) -> bool:
    """True when two materials are one file and their segments share a sample (whole: every sample)."""
    if x[0] != y[0]:
        return False
    if x[1] is None or y[1] is None:
        return True
    return max(x[1], y[1]) < min(x[2], y[2])


def row_labels(row: Mapping[str, Any]) -> list[str]:
    """The speech and noise file labels of a row (stored as JSON lists; absent in old stores)."""
    out: list[str] = []
    for column in ("speech_files", "noise_files"):
        value = row.get(column)
        if isinstance(value, str):
            try:
                value = json.loads(value)
            except ValueError:
                value = [value]
        out += [str(v) for v in value or ()]
    return out


def material_labels(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The distinct materials of ``rows`` as labels without ``@offset`` (a parameter set's ``dev_files``).

    >>> material_labels([{"speech_files": '["/d/s.wav"]', "noise_files": '["/d/n.wav[0:9]@4", "wind:gusts0.5Hz"]'}])
    ['/d/n.wav[0:9]', '/d/s.wav']
    """
    found = set()
    for row in rows:
        for f, a, b in filter(is_material, map(material, row_labels(row))):
            found.add(f if a is None else f"{f}[{a}:{b}]")
    return sorted(found)


class _Files:
    """The tuning materials, by file, for asking whether a row's labels meet them."""

    def __init__(self, labels: Sequence[str]):
        self.by_file: dict[str, list[tuple[str, int | None, int | None]]] = {}
        for m in filter(is_material, (material(str(label)) for label in labels)):
            self.by_file.setdefault(m[0], []).append(m)

    def meets(self, labels: Sequence[str]) -> bool:
        return any(shares(m, t) for m in map(material, labels) for t in self.by_file.get(m[0], ()))


@dataclass(frozen=True)
class Overlap:
    """How many of a tuned system's rows use its tuning material, and why."""

    system: str
    provenance: Mapping[str, Any]
    rows: int
    in_sample: int
    on_split: int
    on_seeds: int
    sharing_files: int

    def record(self) -> dict[str, Any]:
        """One line of ``in_sample.csv``."""
        p = self.provenance
        return {"system": self.system, "parameter_set": p.get("parameter_set"), "tuned_split": p.get("split"),
                "tuned_seeds": " ".join(map(str, p.get("seeds") or ())), "tuned_data": p.get("data"),
                "rows": self.rows, "in_sample_rows": self.in_sample, "on_tuning_split": self.on_split,
                "on_tuning_seeds": self.on_seeds, "sharing_files": self.sharing_files}

    def banner(self) -> str:
        """The warning for the top of a report (the caller shows it only when ``in_sample``)."""
        p = self.provenance
        where = f"parameter set {p['parameter_set']}" if p.get("parameter_set") else "its registry entry"
        why = [f"{self.on_split} on its tuning split", f"{self.on_seeds} on its tuning seeds"]
        if "dev_files" in p:
            why.append(f"{self.sharing_files} sharing speech or noise files with it")
        return (f"In-sample rows: system {self.system} was tuned on {tuning_text(p)} ({where}); "
                f"{self.in_sample} of {self.rows} of its rows here use that material ({', '.join(why)}): "
                "its numbers on those rows are in-sample, not a held-out result.")


def tuning_text(p: Mapping[str, Any]) -> str:
    """``split dev, seeds 0..4, data built-in`` (what a provenance says it was tuned on).

    >>> tuning_text({"split": "dev", "seeds": [0, 1, 2, 3, 4], "data": "built-in"})
    'split dev, seeds 0..4, data built-in'
    """
    seeds = sorted(int(s) for s in p.get("seeds") or ())
    run = seeds and seeds == list(range(seeds[0], seeds[-1] + 1)) and len(seeds) > 2
    shown = f"{seeds[0]}..{seeds[-1]}" if run else (", ".join(map(str, seeds)) or "unknown")
    return f"split {p.get('split', 'unknown')}, seeds {shown}, data {p.get('data', 'unknown')}"


def count_overlap(system: str, rows: Sequence[Mapping[str, Any]], provenance: Mapping[str, Any],
                  data_of) -> Overlap:
    """Count ``system``'s rows that use the material ``provenance`` says it was tuned on.

    ``data_of(row)`` is the data a row drew from (a resolved directory, or ``"built-in"``), in
    the provenance's own spelling (:func:`benchmarks.tune.paramset.data_fingerprint`).
    """
    split, seeds = provenance.get("split"), {int(s) for s in provenance.get("seeds") or ()}
    files = _Files(provenance.get("dev_files") or ())
    n_split = n_seeds = n_files = n_any = 0
    for row in rows:
        same_data = provenance.get("data") is not None and data_of(row) == provenance.get("data")
        row_split = str(row.get("split") or "all")
        on_split = same_data and split is not None and (row_split == split or "all" in (row_split, split))
        on_seeds = on_split and row.get("seed") is not None and int(row["seed"]) in seeds
        on_files = files.meets(row_labels(row))
        n_split, n_seeds, n_files = n_split + on_split, n_seeds + on_seeds, n_files + on_files
        n_any += on_split or on_files
    return Overlap(system, dict(provenance), len(rows), n_any, n_split, n_seeds, n_files)


def _options(run: Mapping[str, Any]) -> dict[str, Any]:
    try:
        return json.loads(run.get("options_json") or "{}")
    except ValueError:
        return {}


def store_overlaps(rows: Sequence[Mapping[str, Any]], runs: Sequence[Mapping[str, Any]]) -> list[Overlap]:
    """One :class:`Overlap` per tuned system of a store's rows, the provenance its rows' run
    recorded (else the last run that recorded one for it); empty for stores without any."""
    tuned_by_run = {r.get("run_id"): _options(r).get("tuned") or {} for r in runs}
    latest: dict[str, Mapping[str, Any]] = {}
    for tuned in tuned_by_run.values():
        latest.update(tuned)
    data = {r.get("run_id"): r.get("data_dir") or "built-in" for r in runs}
    by_system: dict[str, list[Mapping[str, Any]]] = {}
    for row in rows:
        if row.get("enhancer") in latest:
            by_system.setdefault(row["enhancer"], []).append(row)
    out = []
    for system, own in by_system.items():
        by_prov: dict[str, tuple[Mapping[str, Any], list]] = {}
        for row in own:  # rows of one system from runs of different parameter sets count apart
            prov = tuned_by_run.get(row.get("run_id"), {}).get(system) or latest[system]
            by_prov.setdefault(json.dumps(prov, sort_keys=True, default=str), (prov, []))[1].append(row)
        for prov, group in by_prov.values():
            out.append(count_overlap(system, group, prov, lambda r: data.get(r.get("run_id"), "built-in")))
    return out


def overlap_banner(overlaps: Sequence[Overlap]) -> list[str]:
    """The report's warnings: one per tuned system with in-sample rows (empty: none has)."""
    return [o.banner() for o in overlaps if o.in_sample]


def write_overlap_csv(path: str | Path, overlaps: Sequence[Overlap]) -> Path:
    """``in_sample.csv``: per tuned system, its tuning material and how many rows use it."""
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(CSV_COLUMNS))
        writer.writeheader()
        writer.writerows(o.record() for o in overlaps)
    return path
