"""Dev/test splits of a data source: which speech, noise and generator seeds each split may use.

A sweep that tunes anything draws from ``dev``; the numbers it reports as conclusions come from
``test``; ``all`` is every piece of material (the behaviour before splits existed).  The rules:

* **Hash.**  A unit of material goes to ``test`` when the SHA-256 of :data:`SALT` and its key,
  read as a number in [0, 1), is below :data:`TEST_FRACTION`; else to ``dev``.  The key is the
  unit's speaker (``speaker/aew``) where the file name tells it -- CMU ARCTIC names
  (``cmu_arctic_us_aew_a0001.wav`` -> ``aew``) and LibriSpeech names
  (``<speaker>-<chapter>-<utterance>``) -- else the file (``speech/<stem>``, ``noise/<stem>``).
  A speaker never straddles the splits.
* **Manifest.**  ``splits.toml`` in the data directory overrides the hash for what it names::

      dev = ["aew", "cafe_pd.wav"]
      test = ["axb", "noise/wind_cc0.wav"]

  Values are speakers, or files by name, stem or path relative to the directory.
* **Speech in both splits.**  With two or more units, a split the hash leaves empty receives
  the unit of the smallest hash from the other split.  With one speaker (and several files) the
  files are the units (the speaker then straddles: there is no other way to have both splits);
  with one file, the file is cut in time as a noise recording is.
* **Noise in both splits.**  Noise is split by file within its type.  A type whose recordings
  all land on one side (one recording, or all hashed alike) has every recording cut in time:
  ``dev`` takes the first ``1 - TEST_FRACTION`` of its samples, ``test`` the rest.  The split
  point is the same share as the files', and holding out a recording's end is the time-series
  convention (test is what comes after what was tuned on).  The two segments share no sample,
  and a clip loops inside its own segment.
* **Built-in data.**  The artificial voice and the synthesized noises are drawn from generator
  seeds (:func:`split_seed`): ``dev`` uses ``2**64 + 2*seed``, ``test`` ``2**64 + 2*seed + 1``, so
  the two streams share no seed with each other nor with ``all`` (whose seeds stay below
  ``2**63``).  Built-in babble speaks from a fixed bank of talker clips, cut in time like a
  noise recording (:func:`split_pool`).

Examples
--------
>>> side_of("speaker/axb"), side_of("speaker/axb", salt="other salt")
('test', 'dev')
>>> split_seed(3, "all"), split_seed(3, "dev") - 2**64, split_seed(3, "test") - 2**64
(3, 6, 7)
"""

from __future__ import annotations

import hashlib
import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from data_recipes.local import AudioEntry, LocalScan, talker_from_name
from scenesim.errors import ConfigError
from scenesim.validate import check_choice

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

#: The split names a sweep may ask for (``all``: every piece of material).
SPLITS = ("dev", "test", "all")
#: Expected share of units (and of a segmented recording's samples) that go to ``test``.
TEST_FRACTION = 0.3
#: Mixed into every hash: changing it re-deals every unit.
SALT = "scenesim-splits-1"
#: File in a data directory whose ``dev`` / ``test`` lists override the hash.
MANIFEST_NAME = "splits.toml"
#: Built-in seeds of ``dev`` and ``test`` start here (above every seed ``all`` can use).
SPLIT_SEED_BASE = 2**64

_LIBRISPEECH = re.compile(r"^(\d+)-\d+-\d+$")


def split_hash(key: str, *, salt: str = SALT) -> float:
    """The SHA-256 of ``salt``, a NUL and ``key``, its first 8 bytes read as a number in [0, 1)."""
    digest = hashlib.sha256(f"{salt}\0{key}".encode()).digest()
    return int.from_bytes(digest[:8], "big") / 2.0**64


def side_of(key: str, *, salt: str = SALT, test_fraction: float = TEST_FRACTION) -> str:
    """``"test"`` when :func:`split_hash` of ``key`` is below ``test_fraction``, else ``"dev"``."""
    return "test" if split_hash(key, salt=salt) < test_fraction else "dev"


def split_seed(seed: int, split: str) -> int:
    """The generator seed a split draws built-in material with (``all``: ``seed`` itself)."""
    check_choice("split", split, SPLITS)
    return seed if split == "all" else SPLIT_SEED_BASE + 2 * seed + (split == "test")


def speaker_of(path: Path | str) -> str | None:
    """The speaker a speech file's name tells (CMU ARCTIC or LibriSpeech), else ``None``.

    >>> speaker_of("cmu_arctic_us_aew_a0001.wav"), speaker_of("19-198-0001.flac"), speaker_of("a.wav")
    ('aew', '19', None)
    """
    match = _LIBRISPEECH.match(Path(path).stem)
    return match.group(1) if match else talker_from_name(path)


@dataclass(frozen=True)
class Portion:
    """A file of a data directory, whole or the segment ``[start, stop)`` of it (fractions of its length)."""

    entry: AudioEntry
    start: float = 0.0
    stop: float = 1.0

    @property
    def whole(self) -> bool:
        return self.start == 0.0 and self.stop == 1.0

    def cut(self, x: np.ndarray) -> tuple[np.ndarray, str]:
        """``(samples, label)`` of this portion of the decoded file ``x`` (``x`` itself when whole)."""
        if self.whole:
            return x, str(self.entry.path)
        a, b = int(self.start * x.size), int(self.stop * x.size)
        return x[a:b], f"{self.entry.path}[{a}:{b}]"


@dataclass(frozen=True)
class SplitPlan:
    """The material of one split: speech portions, and noise portions per noise type."""

    split: str
    speech: tuple[Portion, ...]
    noise: Mapping[str, tuple[Portion, ...]]
    notes: tuple[str, ...] = ()


@dataclass
class _Unit:
    key: str
    names: frozenset[str]
    entries: list[AudioEntry] = field(default_factory=list)


def segment(entry: AudioEntry, split: str, *, test_fraction: float = TEST_FRACTION) -> Portion:
    """``dev``: the first ``1 - test_fraction`` of a recording; ``test``: the rest."""
    cut = 1.0 - test_fraction
    return Portion(entry, 0.0, cut) if split == "dev" else Portion(entry, cut, 1.0)


def split_pool(items: Sequence, split: str, *, test_fraction: float = TEST_FRACTION) -> list:
    """Babble voices (:class:`~data_recipes.noise_synthesis.SpeechPoolItem`) cut to a split's segment."""
    if split == "all":
        return list(items)
    cut = 1.0 - test_fraction
    out = []
    for item in items:
        n = len(item.signal)
        a, b = (0, int(cut * n)) if split == "dev" else (int(cut * n), n)
        out.append(replace(item, label=f"{item.label}[{a}:{b}]", signal=item.signal[a:b]))
    return out


def plan_split(scan: LocalScan, split: str, *, salt: str = SALT,
               test_fraction: float = TEST_FRACTION) -> SplitPlan:
    """The speech and noise of ``scan`` that ``split`` may use (rules: the module docstring).

    Parameters
    ----------
    scan : LocalScan
        A data directory's usable files (:func:`data_recipes.local.scan_local`); its
        ``splits.toml``, when there is one, overrides the hash.
    split : {"dev", "test", "all"}
    salt : str
        Mixed into every hash (:data:`SALT`).
    test_fraction : float
        Share of units hashed to ``test``, and of a segmented recording's samples.

    Raises
    ------
    ConfigError
        ``splits.toml`` is malformed, names what the directory lacks, lists a name under both
        splits, or leaves a split without speech or without a noise type it can't segment.
    """
    check_choice("split", split, SPLITS)
    if split == "all":
        noise = {t: tuple(Portion(e) for e in scan.noise if e.noise_type == t) for t in scan.noise_types}
        return SplitPlan("all", tuple(Portion(e) for e in scan.speech), noise)
    manifest = read_manifest(scan.root)
    speech_units = _speech_units(scan.speech, scan.root)
    noise_units = {t: [_file_unit(e, scan.root) for e in scan.noise if e.noise_type == t]
                   for t in scan.noise_types}
    manifest.check_known([*speech_units, *(u for us in noise_units.values() for u in us)], scan.root)
    dealer = _Dealer(split, manifest, salt, test_fraction)
    speech = dealer.deal(speech_units, "speech", move=True)
    noise = {t: dealer.deal(units, f"noise type {t!r}", move=False) for t, units in noise_units.items()}
    return SplitPlan(split, speech, noise, tuple(dealer.notes))


def _file_unit(entry: AudioEntry, root: Path, speaker: str | None = None) -> _Unit:
    rel = entry.path.relative_to(root).as_posix() if entry.path.is_relative_to(root) else str(entry.path)
    names = {entry.path.name, entry.path.stem, rel} | ({speaker} if speaker else set())
    return _Unit(f"{entry.kind}/{entry.path.stem}", frozenset(names), [entry])


def _speech_units(entries: Sequence[AudioEntry], root: Path) -> list[_Unit]:
    """One unit per speaker, one per file of unknown speaker; with a single speaker, one per file."""
    units: dict[str, _Unit] = {}
    for entry in entries:
        speaker = speaker_of(entry.path)
        if speaker is None:
            unit = _file_unit(entry, root)
            units[unit.key + "\0" + str(entry.path)] = unit
        else:
            units.setdefault(speaker, _Unit(f"speaker/{speaker}", frozenset({speaker}))).entries.append(entry)
    if len(units) == 1 and len(entries) > 1:
        return [_file_unit(e, root, speaker_of(e.path)) for e in entries]
    return list(units.values())


@dataclass
class _Dealer:
    """Deals units to ``dev`` / ``test`` and keeps the portions of one split."""

    split: str
    manifest: _Manifest
    salt: str
    test_fraction: float
    notes: list[str] = field(default_factory=list)

    def deal(self, units: Sequence[_Unit], what: str, *, move: bool) -> tuple[Portion, ...]:
        entries = [e for u in units for e in u.entries]
        if not entries:
            return ()
        if len(entries) == 1:
            self.manifest.refuse_listed(units[0], f"the only recording of {what}, which is cut in time")
            return self._segments(entries, what, "it has one recording")
        sides: dict[str, list[_Unit]] = {"dev": [], "test": []}
        for unit in units:
            side = self.manifest.side(unit) or side_of(unit.key, salt=self.salt, test_fraction=self.test_fraction)
            sides[side].append(unit)
        for empty, full in (("dev", "test"), ("test", "dev")):
            if sides[empty]:
                continue
            free = [u for u in sides[full] if self.manifest.side(u) is None]
            if not move and len(free) == len(sides[full]):
                return self._segments(entries, what, f"all its recordings hash to {full}")
            if not move or not free:  # the manifest chose this: cutting or moving would overrule it
                raise self.manifest.empties(what, full, empty)
            moved = min(free, key=lambda u: split_hash(u.key, salt=self.salt))
            sides[full].remove(moved)
            sides[empty].append(moved)
            self.notes.append(f"{what}: {moved.key} moved from {full} to {empty}, which was empty")
        chosen = {e for u in sides[self.split] for e in u.entries}
        return tuple(Portion(e) for e in entries if e in chosen)

    def _segments(self, entries: Sequence[AudioEntry], what: str, why: str) -> tuple[Portion, ...]:
        self.notes.append(f"{what}: {why}; dev takes the first {1 - self.test_fraction:.0%} of each, "
                          f"test the rest")
        return tuple(segment(e, self.split, test_fraction=self.test_fraction) for e in entries)


@dataclass(frozen=True)
class _Manifest:
    """A parsed ``splits.toml``: name -> side, and the text for pointing at lines."""

    path: Path
    sides: Mapping[str, str]
    text: str = ""

    def error(self, key: str | None, value: str | None, message: str) -> ConfigError:
        lines = self.text.splitlines()
        at = next((i for i, t in enumerate(lines) if key and re.match(rf"\s*{re.escape(key)}\s*=", t)), 0)
        needle = f'"{value}"' if value is not None else f"{key}"
        line = next((i + 1 for i in range(at, len(lines)) if needle in lines[i]), None)
        where = f": line {line}" if line else ""
        what = (f": key '{key}'" if key else "") + (f": value {value!r}" if value is not None else "")
        return ConfigError(f"{self.path}{where}{what}: {message}")

    def side(self, unit: _Unit) -> str | None:
        found = {self.sides[n] for n in unit.names if n in self.sides}
        if len(found) > 1:
            named = sorted(n for n in unit.names if n in self.sides)
            raise self.error("test", named[-1], f"{unit.key} is also listed under dev as {named[0]!r}")
        return found.pop() if found else None

    def check_known(self, units: Sequence[_Unit], root: Path) -> None:
        known = set().union(*(u.names for u in units)) if units else set()
        speakers = sorted({u.key.split("/", 1)[1] for u in units if u.key.startswith("speaker/")})
        for name, side in self.sides.items():
            if name not in known:
                hint = f" (speakers: {', '.join(speakers)}; a file of a known speaker goes with it)" if speakers else ""
                raise self.error(side, name, f"names no speaker or file in {root}{hint}")

    def refuse_listed(self, unit: _Unit, what: str) -> None:
        side = self.side(unit)
        if side is not None:
            name = sorted(n for n in unit.names if n in self.sides)[0]
            raise self.error(side, name, f"is {what}; leave it out of {MANIFEST_NAME}")

    def empties(self, what: str, full: str, empty: str) -> ConfigError:
        return self.error(full, None, f"puts every unit of {what} in {full}, leaving {empty} without it; "
                                      f"list one under {empty}, or leave one to the hash")


def read_manifest(root: Path) -> _Manifest:
    """``root/splits.toml`` parsed and checked (an empty manifest when there is none).

    Raises
    ------
    ConfigError
        One line naming the file, the key and the value: invalid TOML, a key other than ``dev`` /
        ``test``, a value that is not a list of names, or a name under both keys.
    """
    path = Path(root) / MANIFEST_NAME
    if not path.is_file():
        return _Manifest(path, {})
    text = path.read_text("utf-8")
    empty = _Manifest(path, {}, text)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    sides: dict[str, str] = {}
    for key, values in data.items():
        if key not in ("dev", "test"):
            raise empty.error(key, None, "unknown key; expected dev and test, lists of speakers or file names")
        if not isinstance(values, list) or not all(isinstance(v, str) and v.strip() for v in values):
            raise empty.error(key, None, f"expected a list of speaker or file names, got {values!r}")
        for value in values:
            if sides.get(value, key) != key:
                raise empty.error(key, value, "is listed under both dev and test")
            sides[value] = key
    return _Manifest(path, sides, text)
