"""Which processed file is scored against which reference, and under which system and utterance.

An evaluation scores several *systems* (enhancers, settings) on the same *utterances*; the
per-system summary and the paired comparisons (``scenesim score --out``) group rows by these
two names.  Three ways to say what pairs with what:

* ``--ref FILE``: one reference for every processed file (one utterance, several outputs);
  each processed file is then a system of its own, named by its stem (its path below a
  folder given, without extension), prefixed by as many of its folders as tell two of the same stem apart.
* ``--ref DIR``: each processed folder is a system named by the folder; its audio files are
  found recursively and each pairs with the reference of the same path relative to the
  folder, without the extension (``ss/spk1/u01.wav`` -> ``REF/spk1/u01.flac``), or else with
  the one reference of the same file stem anywhere under ``REF``.  The utterance is that
  reference's relative path without extension.  A processed file given directly belongs to
  the system named by its parent folder.
* a pairs list (``--pairs LIST``): CSV lines ``ref,deg[,system]`` (``#`` comments, blank
  lines and a ``ref,deg...`` header line skipped; relative paths are relative to the list's
  folder); the system defaults to the processed file's parent folder, the utterance is the
  reference as written, without extension.

Without a reference each file is its own utterance (its stem path) of its folder's system.
A processed file with no reference found gets the reason in :attr:`Pair.problem` (its row
fails; the batch goes on).  Two files of one system for the same utterance, or two
processed folders of the same name, raise :class:`DataError` (the summary could not tell
them apart).
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from scenesim.errors import DataError

__all__ = ["AUDIO_SUFFIXES", "Pair", "pair_files", "read_pair_list"]

AUDIO_SUFFIXES = (".wav", ".flac")


@dataclass(frozen=True)
class Pair:
    """One processed file to score: its reference (or None), system and utterance names."""

    degraded: Path
    reference: Path | None
    system: str
    utterance: str
    problem: str = ""  # why the row cannot be scored ('' when it can)


def _audio_under(folder: Path) -> list[Path]:
    files = sorted(p for p in folder.rglob("*")
                   if p.suffix.lower() in AUDIO_SUFFIXES and p.is_file() and not p.name.startswith("."))
    if not files:
        raise DataError(f"{folder} holds no {'/'.join(AUDIO_SUFFIXES)} files (searched recursively)")
    return files


def _stem_path(path: Path, root: Path) -> str:
    return path.relative_to(root).with_suffix("").as_posix()


class _RefIndex:
    """Reference files under a folder, by relative stem path and by bare stem."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.by_key = {_stem_path(p, folder): p for p in _audio_under(folder)}
        self.by_stem: dict[str, list[str]] = {}
        for key in self.by_key:
            self.by_stem.setdefault(key.rsplit("/", 1)[-1], []).append(key)

    def find(self, key: str) -> tuple[str, str]:
        """``(reference key, '')`` for a processed file's key, or ``(key, reason)``."""
        if key in self.by_key:
            return key, ""
        stem = key.rsplit("/", 1)[-1]
        found = self.by_stem.get(stem, [])
        if len(found) == 1:
            return found[0], ""
        why = "several" if found else "no"
        return key, f"{why} reference {stem}.wav/.flac under {self.folder} (pairing is by path or stem)"


def _check_unique(pairs: Sequence[Pair]) -> None:
    seen: dict[tuple[str, str], Path] = {}
    for p in pairs:
        other = seen.setdefault((p.system, p.utterance), p.degraded)
        if other != p.degraded:
            raise DataError(
                f"{other} and {p.degraded} are both system {p.system!r}, utterance {p.utterance!r}: "
                "put systems in separate folders, or name them in a pairs list (ref,deg,system)"
            )


def _system_folders(degraded: Sequence) -> None:
    names: dict[str, Path] = {}
    for arg in degraded:
        path = Path(arg)
        if path.is_dir():
            other = names.setdefault(path.resolve().name, path)
            if other != path:
                raise DataError(
                    f"the folders {other} and {path} are both named {path.resolve().name!r} and systems are "
                    "named by folder: rename one, or name systems in a pairs list (ref,deg,system)"
                )


def _pairs_of(arg, ref: Path | None, index: _RefIndex | None) -> list[Pair]:
    path = Path(arg)
    if not path.exists():
        raise DataError(f"no such file or folder: {path}")
    if path.is_dir():
        system, items = path.resolve().name, [(f, _stem_path(f, path)) for f in _audio_under(path)]
    else:
        system, items = path.resolve().parent.name, [(path, path.stem)]
    pairs = []
    for file, key in items:
        if ref is None:
            pairs.append(Pair(file, None, system, key))
        elif index is None:  # one reference: every processed file is a system of its own
            pairs.append(Pair(file, ref, key, ref.stem))
        else:
            ref_key, problem = index.find(key)
            pairs.append(Pair(file, None if problem else index.by_key[ref_key], system, ref_key, problem))
    return pairs


def pair_files(degraded: Sequence, reference=None) -> list[Pair]:
    """Pairs from processed files/folders and a reference file or folder (module docstring).

    >>> import tempfile, pathlib, numpy as np, soundfile as sf
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for sub in ("ref/spk", "ss/spk", "eb/spk"):
    ...     (root / sub).mkdir(parents=True)
    ...     sf.write(root / sub / "u1.wav", np.zeros(160), 16000)
    >>> [(p.system, p.utterance) for p in pair_files([root / "ss", root / "eb"], root / "ref")]
    [('ss', 'spk/u1'), ('eb', 'spk/u1')]
    """
    ref = None if reference is None else Path(reference)
    if ref is not None and not ref.exists():
        raise DataError(f"no such reference file or folder: {ref} (--ref)")
    index = _RefIndex(ref) if ref is not None and ref.is_dir() else None
    _system_folders(degraded)
    pairs = [p for arg in degraded for p in _pairs_of(arg, ref, index)]
    if ref is not None and index is None:
        pairs = _distinct_systems(pairs)
    _check_unique(pairs)
    return pairs


def _distinct_systems(pairs: list[Pair]) -> list[Pair]:
    """One reference, outputs of the same name (a/u1.wav, b/u1.wav): name each system by the
    fewest trailing path parts that tell them apart (a/u1, b/u1)."""
    parts = [p.degraded.resolve().with_suffix("").parts for p in pairs]
    for k in range(1, max(map(len, parts)) + 1):
        names = ["/".join(q[-k:]) for q in parts]
        if len(set(names)) == len(names):
            return pairs if k == 1 else [replace(p, system=n) for p, n in zip(pairs, names)]
    return pairs  # the same file twice: _check_unique names it


def _list_row(line_no: int, cells: list[str], base: Path, source: Path) -> Pair:
    if len(cells) not in (2, 3) or not all(cells[:2]):
        raise DataError(f"{source} line {line_no}: expected ref,deg[,system], got {','.join(cells)!r}")
    ref, deg = (Path(c) if Path(c).is_absolute() else base / c for c in cells[:2])
    system = cells[2] if len(cells) == 3 and cells[2] else deg.resolve().parent.name
    missing = next((f"no such file: {p}" for p in (deg, ref) if not p.is_file()), "")
    return Pair(deg, ref, system, Path(cells[0]).with_suffix("").as_posix(), missing)


def read_pair_list(path) -> list[Pair]:
    """Pairs from a list file of CSV lines ``ref,deg[,system]`` (module docstring).

    A listed file that does not exist fails its row only; a malformed line raises
    :class:`DataError` naming the file and line.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"no such pairs list: {path} (--pairs)")
    pairs = []
    with open(path, newline="", encoding="utf-8") as stream:
        for line_no, cells in enumerate(csv.reader(stream), start=1):
            cells = [c.strip() for c in cells]
            if not cells or not any(cells) or cells[0].startswith("#"):
                continue
            if line_no == 1 and cells[:2] == ["ref", "deg"]:
                continue
            pairs.append(_list_row(line_no, cells, path.parent, path))
    if not pairs:
        raise DataError(f"{path} lists no pairs (expected lines ref,deg[,system])")
    _check_unique(pairs)
    return pairs
