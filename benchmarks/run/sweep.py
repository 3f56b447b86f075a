"""Sweep files: TOML parsing, validation with line numbers, and deterministic condition expansion.

A sweep is a TOML file (the presets ship in ``benchmarks/presets``)::

    [sweep]
    name = "thesis"
    description = "..."

    [axes]                      # lists: the sweep is their Cartesian product
    enhancers = ["eb", "ss", "eb-ss", "passthrough"]
    noise = ["babble", "factory", "wind"]
    snr_db = [0, 5, 10, 15, 20, 25]
    rt60_s = [0.0]              # 0 = anechoic free field
    seeds = [0]

    [fixed]                     # single values for everything else
    fs = 16000
    duration_s = 8.0

    [rooms.office]              # named rooms an axis ``room = ["office"]`` refers to
    dims_m = [5.0, 4.0, 2.8]
    pair_center_m = [2.0, 1.8, 0.9]

    [enhancer_params.eb]        # constructor overrides per enhancer name
    mu = 0.1

    [parameter_sets]            # a tuned system: its name (listed in axes.enhancers) = a params.toml
    eb-robust-tuned = "tune-eb/params.toml"

A ``[parameter_sets]`` entry runs the parameter set ``scenesim tune`` wrote (a path relative to the
sweep file's folder, else to the working directory) as a system of its own: its enhancer with its
parameters, named as the key; the run records the set's provenance (what it was tuned on) and the
report says when its rows use that material (:mod:`benchmarks.run.parameter_sets`).

A sweep draws its speech and noise from one split of the data, ``split = "dev" | "test" | "all"``
in ``[sweep]`` or ``[fixed]`` (default ``"all"``: every file and seed; :mod:`data_recipes.splits`);
a split is no axis: every row of a run has the one split, stored per row.

Every condition parameter (see :data:`PARAMETERS`) may be an axis (a list in ``[axes]``) or
fixed (a scalar in ``[fixed]``), never both; ``seeds`` is the axis spelling of ``seed``.
A *condition* is one scene x noise x SNR x seed; a results row is one (condition, enhancer).
Its id is a short SHA-256 of the canonical JSON of its parameters (not of the enhancer),
so it is the same in every process and on every machine.  Expansion order is the
Cartesian product with SNR innermost (conditions of one geometry are adjacent, so a
worker reuses the rendered scene) and noise just outside it: the first thesis condition
is babble at 0 dB.

Bad files raise :class:`~scenesim.errors.ConfigError` naming the key and its line.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import itertools
import json
import math
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.run.parameter_sets import ParameterSet, load_parameter_set
from data_recipes.splits import SPLITS
from scenesim.errors import ConfigError, ExtraNotInstalled, ParameterError, ScenesimError
from scenesim.room.shoebox import RT60_METHODS
from scenesim.scene.compose import NOISE_FIELDS, REFERENCES, SNR_MODES
from scenesim.scene.thesis_farfield import AZIMUTH_CONVENTIONS, FD_WINDOWS
from scenesim.validate import (
    PHYSICAL_RANGES,
    check_outside_pair,
    check_physical,
    check_seed,
    check_snr_band,
)

FAR_FIELD_METHODS = ("exact", "thesis")

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

PRESETS = ("thesis", "thesis-text", "thesis-fit", "thesis-repro", "phone", "mismatch", "peers", "reverb",
           "distance", "angles", "smoke")
"""Names of the sweeps shipped in ``benchmarks/presets`` (contract.md: fixed names)."""

ID_VERSION = 1

MAX_CONDITIONS = 1_000_000
"""The most conditions one sweep may expand to (about a CPU-year at a second each): larger is a typo."""
"""Bumped if the canonical parameter set changes meaning (changes every condition id)."""

MIN_WALL_DISTANCE_M = 0.1  # scenesim.room.shoebox.ShoeBox's default: sources and mics keep off the walls
SUPPORTED_FS = (8000, 16000)  # PESQ accepts only these


# -- validators: value -> normalised value, or raise ValueError("what was expected") -----------


def _number(value, *, lo=-math.inf, hi=math.inf, lo_open=False, what="a finite number"):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(what)
    value = float(value)
    if not math.isfinite(value) or value < lo or value > hi or (lo_open and value == lo):
        raise ValueError(what)
    return value


def _finite(value):
    return _number(value)


def _positive(value):
    return _number(value, lo=0.0, lo_open=True, what="a number > 0")


def _seed(value):
    try:
        return check_seed("seed", value)
    except ParameterError as exc:
        raise ValueError(exc.allowed) from None


def _physical(quantity):
    """The validator of a quantity of :data:`scenesim.validate.PHYSICAL_RANGES` (shared with the CLI)."""

    def check(value):
        try:
            return check_physical(quantity, value, quantity)
        except ParameterError as exc:
            raise ValueError(exc.allowed) from None

    return check


def _fs(value):
    if isinstance(value, bool) or not isinstance(value, int) or value not in SUPPORTED_FS:
        raise ValueError("one of " + ", ".join(map(str, SUPPORTED_FS)) + " (Hz)")
    return int(value)


def _bool(value):
    if not isinstance(value, bool):
        raise ValueError("true or false")
    return value


def _choice(choices):
    def check(value):
        if not isinstance(value, str) or value not in choices:
            raise ValueError("one of " + ", ".join(repr(c) for c in choices))
        return value

    return check


#: Metrics a sweep opts into with its ``metrics`` key (costly ones, not computed by default).
OPTIONAL_METRICS = ("dnsmos",)


def _metric_list(value):
    # A list of optional metric names: the canonical form is a sorted tuple without repeats.
    if not isinstance(value, list) or not all(isinstance(v, str) and v in OPTIONAL_METRICS for v in value):
        raise ValueError("a list of optional metrics among " + ", ".join(repr(m) for m in OPTIONAL_METRICS))
    return tuple(sorted(set(value)))


_NAME_RE = re.compile(r"^[a-z0-9][a-z0-9_-]*$")


def _in_range(lo, hi, unit):
    def check(value):
        return _number(value, lo=lo, hi=hi, what=f"a number in [{lo:g}, {hi:g}] ({unit})")

    return check


def _or_none(check, word):
    """``check``, or the string ``word`` meaning None (TOML has no null)."""

    def wrapped(value):
        if value == word:
            return None
        try:
            return check(value)
        except ValueError as exc:
            raise ValueError(f"{exc} or {word!r}") from None

    return wrapped


def _corners(value):
    # One corner for both mics, or [front, rear]; 0 = no high-pass.
    lo, hi = PHYSICAL_RANGES["highpass_hz"][:2]
    what = f"a corner in Hz in [{lo:g}, {hi:g}], or [front, rear]"
    if isinstance(value, list):
        if len(value) != 2:
            raise ValueError(what)
        return tuple(_number(v, lo=lo, hi=hi, what=what) for v in value)
    v = _number(value, lo=lo, hi=hi, what=what)
    return (v, v)


def _pair_of(lo, hi, what):
    def check(value):
        if not isinstance(value, list) or len(value) != 2:
            raise ValueError(what)
        a, b = (_number(v, lo=lo, hi=hi, what=what) for v in value)
        if not a < b:
            raise ValueError(what)
        return (a, b)

    return check


def _odd_taps(value):
    if isinstance(value, bool) or not isinstance(value, int) or value < 1 or value > 1025 or value % 2 == 0:
        raise ValueError("an odd integer in [1, 1025] (taps)")
    return int(value)


def _noise_field(value):
    # A field for every noise, or a table noise type -> field (each noise its own field).
    if isinstance(value, dict):
        out = []
        for noise, field_ in sorted(value.items()):
            _noise_type(noise)
            out.append((noise, _choice(NOISE_FIELDS)(field_)))
        if not out:
            raise ValueError("a non-empty table noise = field")
        return tuple(out)
    return _choice(NOISE_FIELDS)(value)


def _noise_type(value):
    # Noise types name files "<type>[_<anything>].wav": lower-case, no underscore.
    if not isinstance(value, str) or not _NAME_RE.match(value) or "_" in value:
        raise ValueError("a noise type name such as 'babble' (lower case, no underscore)")
    return value


def _room_name(value):
    if value is None:
        return None
    if not isinstance(value, str) or not value:
        raise ValueError("the name of a [rooms.<name>] table")
    return value


@dataclass(frozen=True)
class _Param:
    check: Callable[[Any], Any]
    default: Any  # _REQUIRED for none
    doc: str


_REQUIRED = object()

PARAMETERS: dict[str, _Param] = {
    # Order = expansion order, outermost first: geometry outside, noise then SNR innermost.
    "fs": _Param(_fs, 16000, "sampling rate in Hz"),
    "duration_s": _Param(_physical("duration_s"), 8.0, "length of the speech and noise signals in s"),
    "noise_field": _Param(
        _noise_field, "point", "noise field type, or a table noise type -> field type"
    ),
    "far_field": _Param(_bool, True, "plane-wave (far-field) free-field propagation"),
    # The source thesis' own far-field simulation (scenesim.scene.thesis_farfield); exact = ours.
    "far_field_method": _Param(_choice(FAR_FIELD_METHODS), "exact", "far-field model: 'exact' or the thesis' 'thesis'"),
    "fd_taps": _Param(_odd_taps, 33, "thesis model: truncated-sinc length (odd)"),
    "fd_window": _Param(_choice(FD_WINDOWS), "rect", "thesis model: window of the truncated sinc"),
    "azimuth_from": _Param(_choice(AZIMUTH_CONVENTIONS), "axis", "thesis model: angles from the 'axis' or 'broadside'"),
    "spacing_m": _Param(_physical("spacing_m"), 0.0214, "mic spacing in m"),
    # The sensors (scenesim.scene.sensors): nominal rear-re-front mismatch, high-pass corners,
    # self-noise against a speech level, and the production spread drawn per seed.
    "mic_gain_db": _Param(_in_range(-10.0, 10.0, "dB"), 0.0, "rear mic sensitivity re front in dB"),
    "mic_phase_deg": _Param(_in_range(-90.0, 90.0, "deg"), 0.0, "rear mic phase re front in deg"),
    "mic_highpass_hz": _Param(_corners, (0.0, 0.0), "first-order high-pass corner(s) in Hz"),
    "self_noise_dba": _Param(
        _or_none(_in_range(-20.0, 120.0, "dBA SPL"), "none"), None, "mic self-noise in dBA SPL"
    ),
    "speech_spl_db": _Param(_in_range(20.0, 120.0, "dB SPL"), 65.0, "talker level at the reference mic"),
    "mic_gain_tol_db": _Param(_in_range(0.0, 6.0, "dB"), 0.0, "each mic's sensitivity spread +- dB"),
    "mic_phase_tol_deg": _Param(_in_range(0.0, 45.0, "deg"), 0.0, "rear mic phase spread +- deg"),
    "mic_highpass_tol_hz": _Param(_in_range(0.0, 500.0, "Hz"), 0.0, "each corner's spread +- Hz"),
    "wind_speed_mps": _Param(_in_range(0.1, 50.0, "m/s"), 5.0, "wind speed of the 'wind' field"),
    "snr_band_hz": _Param(
        _or_none(_pair_of(0.0, 24000.0, "[lo, hi] in Hz with lo < hi"), "full"),
        None,
        "band in which the input SNR is set ('full': whole band)",
    ),
    "noise_az_range_deg": _Param(
        _or_none(_pair_of(-360.0, 720.0, "[lo, hi] in deg with lo < hi"), "none"),
        None,
        "draw the point-noise azimuth per seed uniformly in [lo, hi] (overrides noise_az_deg)",
    ),
    "speech_az_range_deg": _Param(
        _or_none(_pair_of(-360.0, 720.0, "[lo, hi] in deg with lo < hi"), "none"),
        None,
        "draw the talker azimuth per seed uniformly in [lo, hi] (overrides speech_az_deg)",
    ),
    "distance_range_m": _Param(
        _or_none(_pair_of(0.01, 100.0, "[lo, hi] in m with lo < hi"), "none"),
        None,
        "draw the talker distance per seed uniformly in [lo, hi] (overrides distance_m)",
    ),
    "early_window_ms": _Param(
        _in_range(0.0, 500.0, "ms"), 50.0, "early window after the direct path kept in the 'early50' target"
    ),
    "rt60_method": _Param(_choice(RT60_METHODS), "calibrated", "how rt60_s sets absorption"),
    "metrics": _Param(_metric_list, (), "optional metrics to compute too, e.g. ['dnsmos'] (DNSMOS P.835)"),
    "snr_mode": _Param(_choice(SNR_MODES), "total", "how the input SNR is defined"),
    "reference": _Param(_choice(REFERENCES), "direct", "reference speech for the metrics"),
    "room": _Param(_room_name, None, "a room name from [rooms.<name>] (ignored when rt60_s = 0)"),
    "rt60_s": _Param(_physical("rt60_s"), 0.0, "reverberation time in s; 0 = anechoic free field"),
    "noise_distance_m": _Param(_physical("distance_m"), 1.0, "noise source distance from the pair centre in m"),
    "distance_m": _Param(_physical("distance_m"), 1.0, "talker distance from the pair centre in m"),
    "speech_az_deg": _Param(_physical("azimuth_deg"), 45.0, "talker azimuth in degrees (endfire = 0)"),
    "noise_az_deg": _Param(_physical("azimuth_deg"), 270.0, "noise source azimuth in degrees"),
    "noise": _Param(_noise_type, _REQUIRED, "noise type"),
    "seed": _Param(_seed, 0, "seed of the speech/noise excerpts and the scene"),
    "snr_db": _Param(_physical("snr_db"), _REQUIRED, "input SNR in dB"),
}

_AXIS_ALIASES = {"seeds": "seed"}  # axis spelling -> parameter
_TOP_TABLES = ("sweep", "axes", "fixed", "rooms", "enhancer_params", "parameter_sets")
_SWEEP_KEYS = ("name", "description", "split", "ranking")
#: Metrics a sweep's ``[sweep] ranking = [...]`` may name (result columns, higher is better); the
#: report ranks by them in turn (:mod:`benchmarks.report.ranking`).
RANKABLE_METRICS = ("pesq_wb_out", "pesq_nb_out", "pesq_nb_raw_out", "estoi_out", "stoi_out", "si_sdr_out_db",
                    "si_sdr_i_db", "snr_i_db", "sinr_i_db", "srmr_out", "dnsmos_ovrl", "dnsmos_sig", "dnsmos_bak",
                    "dnsmos_p808")
#: The field's metrics, the report's ranking rule when a sweep gives none: wide-band PESQ
#: (P.862.2 MOS-LQO), ESTOI, SI-SDR, then DNSMOS P.835 OVRL where computed.
DEFAULT_RANKING = ("pesq_wb_out", "estoi_out", "si_sdr_out_db", "dnsmos_ovrl")
_ROOM_KEYS = ("dims_m", "pair_center_m", "axis_azimuth_deg")


# -- values --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Room:
    """A named shoebox room of a sweep: dimensions and where the phone (pair centre) is."""

    name: str
    dims_m: tuple[float, float, float]
    pair_center_m: tuple[float, float, float]
    axis_azimuth_deg: float = 0.0


@dataclass(frozen=True)
class Condition:
    """One scene x noise x SNR x seed of a sweep (every enhancer is run on it).

    ``room_dims_m`` is None for the anechoic free field (``rt60_s == 0``), where the pair
    sits at the origin.  ``id`` is the short SHA-256 of :meth:`canonical`.
    """

    noise: str
    snr_db: float
    rt60_s: float
    speech_az_deg: float
    noise_az_deg: float | None
    distance_m: float
    noise_distance_m: float | None
    seed: int
    fs: int
    duration_s: float
    noise_field: str
    far_field: bool
    spacing_m: float
    rt60_method: str
    snr_mode: str
    reference: str
    room: str | None = None
    room_dims_m: tuple[float, float, float] | None = None
    pair_center_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis_azimuth_deg: float = 0.0
    mic_gain_db: float = 0.0
    mic_phase_deg: float = 0.0
    mic_highpass_hz: tuple[float, float] = (0.0, 0.0)
    self_noise_dba: float | None = None
    speech_spl_db: float = 65.0
    mic_gain_tol_db: float = 0.0
    mic_phase_tol_deg: float = 0.0
    mic_highpass_tol_hz: float = 0.0
    wind_speed_mps: float = 5.0
    snr_band_hz: tuple[float, float] | None = None
    noise_az_range_deg: tuple[float, float] | None = None
    speech_az_range_deg: tuple[float, float] | None = None
    distance_range_m: tuple[float, float] | None = None
    early_window_ms: float = 50.0
    far_field_method: str = "exact"
    fd_taps: int = 33
    fd_window: str = "rect"
    azimuth_from: str = "axis"
    metrics: tuple[str, ...] = ()
    split: str = "all"

    def canonical(self) -> dict[str, Any]:
        """Every parameter as plain JSON types (floats as floats, so 5 and 5.0 agree).

        Keys added after the first release enter only when they differ from their default
        (:data:`_LATE_DEFAULTS`), so every condition that existed before them keeps its id.
        """
        out: dict[str, Any] = {"v": ID_VERSION}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in _LATE_DEFAULTS and value == _LATE_DEFAULTS[f.name]:
                continue
            if isinstance(value, tuple):
                value = [v if isinstance(v, str) else float(v) for v in value]
            elif isinstance(value, float):
                value = float(value)
            out[f.name] = value
        return out

    @property
    def ideal_sensors(self) -> bool:
        """True for the thesis' idealisation: identical noiseless mics with no spread."""
        return all(
            getattr(self, k) == _LATE_DEFAULTS[k]
            for k in ("mic_gain_db", "mic_phase_deg", "mic_highpass_hz", "self_noise_dba",
                      "mic_gain_tol_db", "mic_phase_tol_deg", "mic_highpass_tol_hz")
        )  # fmt: skip

    def to_json(self) -> str:
        return json.dumps(self.canonical(), sort_keys=True, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str) -> Condition:
        values = json.loads(text)
        values.pop("v", None)
        for key in ("room_dims_m", "pair_center_m", "mic_highpass_hz", "snr_band_hz", "noise_az_range_deg",
                    "speech_az_range_deg", "distance_range_m", "metrics"):
            if values.get(key) is not None:
                values[key] = tuple(values[key])
        return cls(**values)

    @property
    def id(self) -> str:
        """16 hex digits of SHA-256 over the canonical JSON: stable across runs and machines."""
        return _short_hash(self.to_json())

    @property
    def group_id(self) -> str:
        """Id of the geometry group: everything but the SNR (rendered once, mixed per SNR)."""
        params = self.canonical()
        params.pop("snr_db")
        return _short_hash(json.dumps(params, sort_keys=True, separators=(",", ":")))

    def label(self) -> str:
        room = "free field" if self.room_dims_m is None else f"{self.room} RT60 {self.rt60_s:g} s"
        where = f"noise {self.noise_az_deg:g} deg" if self.noise_az_deg is not None else f"{self.noise_field} noise"
        split = "" if self.split == "all" else f", split {self.split}"
        return f"{self.noise} {self.snr_db:g} dB, {room}, speech {self.speech_az_deg:g} deg, {where}, seed {self.seed}{split}"


_LATE_DEFAULTS: dict[str, Any] = {
    "mic_gain_db": 0.0,
    "mic_phase_deg": 0.0,
    "mic_highpass_hz": (0.0, 0.0),
    "self_noise_dba": None,
    "speech_spl_db": 65.0,
    "mic_gain_tol_db": 0.0,
    "mic_phase_tol_deg": 0.0,
    "mic_highpass_tol_hz": 0.0,
    "wind_speed_mps": 5.0,
    "snr_band_hz": None,
    "noise_az_range_deg": None,
    "speech_az_range_deg": None,
    "distance_range_m": None,
    "early_window_ms": 50.0,
    "far_field_method": "exact",
    "fd_taps": 33,
    "fd_window": "rect",
    "azimuth_from": "axis",
    "metrics": (),
    "split": "all",
}
"""Condition keys added after the first release, with the value that leaves them out of the id."""

_AZIMUTH_STREAM = 11  # rng stream of per-seed noise azimuth draws
_TALKER_STREAM = 12  # rng stream of per-seed talker azimuth and distance draws


def _short_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep file: enhancers, per-enhancer params and the axes to expand.

    Attributes
    ----------
    name, description : str
    source : str
        Preset name or file path it was read from.
    text : str
        The TOML text (recorded in the store's ``runs`` table).
    enhancers : tuple of str
    enhancer_params : mapping name -> dict
    axes : mapping parameter -> tuple of values (one value for fixed parameters)
    rooms : mapping name -> Room
    split : {"all", "dev", "test"}
        The data split every condition draws from (:mod:`data_recipes.splits`); part of each
        condition's id (except ``"all"``), not of the sweep's version.
    ranking : tuple of str
        ``[sweep] ranking``: the metrics the report ranks by, in turn (:data:`RANKABLE_METRICS`;
        empty: :data:`DEFAULT_RANKING`).  Decides no number of a row: not part of the version.
    parameter_sets : mapping name -> (path, ParameterSet)
        ``[parameter_sets]``: systems built from a tuned parameter set (the file's resolved path
        and its contents); their parameters are also in ``enhancer_params``.
    """

    name: str
    description: str
    source: str
    text: str
    enhancers: tuple[str, ...]
    enhancer_params: Mapping[str, Mapping[str, Any]]
    axes: Mapping[str, tuple]
    rooms: Mapping[str, Room] = field(default_factory=dict)
    seed_offset: int = 0
    split: str = "all"
    ranking: tuple[str, ...] = ()
    parameter_sets: Mapping[str, tuple[str, ParameterSet]] = field(default_factory=dict)

    def registered_name(self, name: str) -> str:
        """The registry name that builds system ``name``: its parameter set's enhancer, else itself.

        >>> load_sweep("smoke").registered_name("eb")
        'eb'
        """
        return self.parameter_sets[name][1].enhancer if name in self.parameter_sets else name

    def conditions(self) -> list[Condition]:
        """All conditions in deterministic order (Cartesian product, SNR innermost).

        Conditions that describe the same scene are listed once: with ``rt60_s = 0`` the
        room is ignored, so two rooms give one anechoic condition.
        """
        names = list(PARAMETERS)
        seen: set[str] = set()
        out: list[Condition] = []
        for combo in itertools.product(*(self.axes[n] for n in names)):
            values = dict(zip(names, combo))
            values["seed"] += self.seed_offset
            values["split"] = self.split
            cond = _make_condition(values, self.rooms)
            if cond.id not in seen:
                seen.add(cond.id)
                out.append(cond)
        return out

    def with_seed(self, seed: int) -> Sweep:
        """The same sweep with the seeds axis offset by ``seed`` (``seeds = [0]`` becomes ``[seed]``)."""
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ParameterError("seed", seed, "an integer >= 0")
        top = max(self.axes["seed"]) + self.seed_offset
        limit = PHYSICAL_RANGES["seed"][1] - top  # the store keeps seeds as SQLite's 64-bit integers
        if seed > limit:
            raise ParameterError("seed", seed, f"an integer in [0, {limit}] (the sweep's seeds go up to {top})")
        return dataclasses.replace(self, seed_offset=self.seed_offset + seed)

    def with_split(self, split: str) -> Sweep:
        """The same sweep drawing from data split ``split`` (``bench run --split``).

        >>> load_sweep("smoke").with_split("dev").conditions()[0].split
        'dev'
        """
        if not isinstance(split, str) or split not in SPLITS:
            raise ParameterError("split", split, "one of " + ", ".join(repr(s) for s in SPLITS))
        return dataclasses.replace(self, split=split)

    def with_seeds(self, n: int) -> Sweep:
        """The same sweep with its seed list replaced by ``0 .. n-1`` (``bench run --seeds N``).

        >>> float(len(load_sweep("smoke").with_seeds(3).axes["seed"]))
        3.0
        """
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ParameterError("seeds", n, "an integer >= 1")
        per_seed = math.prod(len(v) for k, v in self.axes.items() if k != "seed")
        if n > MAX_CONDITIONS // max(per_seed, 1):  # checked before any list is built: a typo must not hang
            raise ParameterError("seeds", n, f"at most {MAX_CONDITIONS // max(per_seed, 1):,} for this sweep "
                                             f"({per_seed} conditions per seed, {MAX_CONDITIONS:,} in one sweep)")
        return dataclasses.replace(self, axes={**self.axes, "seed": tuple(range(n))})

    def missing_extras(self) -> list[str]:
        """One line per optional extra this sweep needs and this install lacks (empty: runnable).

        An enhancer behind an extra (``peers``' black boxes) or an optional metric (``metrics =
        ["dnsmos"]``) would otherwise run and store empty columns; ``bench run`` refuses first.

        >>> load_sweep("smoke").missing_extras()
        []
        """
        from enhancers.core.registry import get_spec

        out = []
        for name in self.enhancers:
            spec = get_spec(self.registered_name(name))
            if spec.not_installed is not None:
                out.append(f"enhancer {name!r} is not installed: {spec.not_installed}")
        metrics = set().union(*(set(m) for m in self.axes.get("metrics", ((),))))
        if "dnsmos" in metrics and not all(importlib.util.find_spec(m) for m in ("speechmos", "onnxruntime")):
            out.append(str(ExtraNotInstalled("dnsmos", "the metric 'dnsmos'")))
        return out

    @property
    def swept_axes(self) -> tuple[str, ...]:
        """The parameters that take more than one value (``seed`` included)."""
        return tuple(k for k, v in self.axes.items() if len(v) > 1)

    @property
    def n_conditions(self) -> int:
        return len(self.conditions())


def stratified(conditions: Sequence[Any], n: int, axes: Sequence[str], *, value: Callable[[Any, str], Any] | None = None) -> list[Any]:
    """``n`` of ``conditions`` spread over every axis in ``axes`` (``bench run --limit N``).

    Greedy balancing: each pick is the condition whose axis values (and pairs of values)
    have been picked least so far, ties to the earliest in the sweep's order, so the first
    pick is the first condition and every axis value is taken before any is taken twice.
    Returned in the sweep's order.  ``value(item, axis)`` reads an axis value (default:
    the attribute of that name), so any items can be spread, e.g. results rows.

    >>> sw = load_sweep("thesis")
    >>> sorted({c.noise for c in stratified(sw.conditions(), 3, sw.swept_axes)})
    ['babble', 'factory', 'wind']
    """
    conditions = list(conditions)
    if n >= len(conditions):
        return conditions
    value = value or (lambda c, a: getattr(c, a, None))
    keys = [[(a, repr(value(c, a))) for a in axes] for c in conditions]
    counts: dict[Any, int] = {}
    chosen: list[int] = []
    left = set(range(len(conditions)))
    for _ in range(n):
        def score(i):
            single = sum(counts.get(k, 0) for k in keys[i])
            pairs = sum(counts.get(p, 0) for p in itertools.combinations(keys[i], 2))
            return (single, pairs, i)

        best = min(left, key=score)
        left.discard(best)
        chosen.append(best)
        for k in (*keys[best], *itertools.combinations(keys[best], 2)):
            counts[k] = counts.get(k, 0) + 1
    return [conditions[i] for i in sorted(chosen)]



def _draw_talker(values: dict[str, Any]) -> None:
    """Per-seed talker azimuth / distance from ``speech_az_range_deg`` / ``distance_range_m``.

    One draw per seed (the same in every room and RT60 of the sweep, so RT60s compare the same
    placements); the ranges stay in the condition, so its rows are no azimuth/distance sweep.
    """
    u = np.random.default_rng([values["seed"], _TALKER_STREAM]).uniform(size=2)
    for key, range_key, k in (("speech_az_deg", "speech_az_range_deg", 0), ("distance_m", "distance_range_m", 1)):
        lo_hi = values[range_key]
        if lo_hi is not None:
            values[key] = float(round(lo_hi[0] + u[k] * (lo_hi[1] - lo_hi[0]), 6))


def _make_condition(values: dict[str, Any], rooms: Mapping[str, Room]) -> Condition:
    room_name = values.pop("room")
    az_range = values.pop("noise_az_range_deg")
    _draw_talker(values)
    field_ = values["noise_field"]
    if isinstance(field_, tuple):  # a table noise type -> field
        values["noise_field"] = field_ = dict(field_)[values["noise"]]
    if field_ == "point":
        if az_range is not None:
            # One draw per seed (the same for every noise): a spread of phone orientations.
            # The range stays in the condition: its rows are no azimuth sweep.
            u = np.random.default_rng([values["seed"], _AZIMUTH_STREAM]).uniform()
            values["noise_az_deg"] = round(az_range[0] + u * (az_range[1] - az_range[0]), 6)
            values["noise_az_range_deg"] = az_range
    else:
        # Fields have no place: one condition whatever the azimuth/distance axes say.
        values["noise_az_deg"] = None
        values["noise_distance_m"] = None
    if field_ != "wind":
        values["wind_speed_mps"] = _LATE_DEFAULTS["wind_speed_mps"]
    if values["far_field_method"] == "exact" or values["rt60_s"] != 0.0 or not values["far_field"]:
        # The thesis model is a far-field free-field one: elsewhere its keys mean nothing.
        for key in ("far_field_method", "fd_taps", "fd_window", "azimuth_from"):
            values[key] = _LATE_DEFAULTS[key]
    if values["rt60_s"] == 0.0:
        # Anechoic free field: no room, pair at the origin; the room name does not matter.
        return Condition(**values)
    room = rooms[room_name]
    return Condition(
        **values,
        room=room.name,
        room_dims_m=room.dims_m,
        pair_center_m=room.pair_center_m,
        axis_azimuth_deg=room.axis_azimuth_deg,
    )


# -- loading -------------------------------------------------------------------------------


#: Old preset names that load another preset's file (the rows carry the new name).
PRESET_ALIASES = {"thesis-repro": "thesis-fit"}


def preset_text(name: str) -> str:
    """The TOML text of a shipped preset (an alias reads its target's file)."""
    if name not in PRESETS:
        raise ConfigError(f"unknown preset {name!r}: expected one of {', '.join(PRESETS)} or a .toml file")
    name = PRESET_ALIASES.get(name, name)
    return resources.files("benchmarks").joinpath("presets", f"{name}.toml").read_text("utf-8")


def load_sweep(preset_or_path: str | Path) -> Sweep:
    """Read a preset by name (``"thesis"``) or a sweep TOML file by path.

    Raises
    ------
    ConfigError
        The file is missing, is not valid TOML, or has an unknown key, a wrong type or a
        bad value; the message names the key and its line.
    """
    text_arg = str(preset_or_path)
    path = Path(text_arg)
    if text_arg in PRESETS and not path.is_file():
        return parse_sweep(preset_text(text_arg), source=text_arg, default_name=text_arg)
    if path.is_dir():
        raise ConfigError(f"{text_arg} is a directory: expected a preset ({', '.join(PRESETS)}) or a .toml file")
    if path.suffix.lower() != ".toml" and not path.is_file():
        raise ConfigError(
            f"unknown preset {text_arg!r}: expected one of {', '.join(PRESETS)} or a .toml file"
        )
    try:
        text = path.read_text("utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read sweep file {text_arg}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        line = path.read_bytes()[: exc.start].count(b"\n") + 1
        raise ConfigError(f"{text_arg}: line {line}: not UTF-8 text (byte {exc.object[exc.start]:#04x}); "
                          "save the sweep file as UTF-8") from None
    return parse_sweep(text, source=text_arg, default_name=path.stem)


def parse_sweep(text: str, *, source: str = "<string>", default_name: str = "sweep") -> Sweep:
    """Parse and validate sweep TOML ``text`` (see the module docstring for the format)."""
    return _Parser(text, source).parse(default_name)


class _Parser:
    def __init__(self, text: str, source: str):
        self.text = text
        self.source = source
        self.lines = _KeyLines(text)

    # Every error goes through here so it always names the key and the line.
    def error(self, table: tuple[str, ...], key: str | None, message: str) -> ConfigError:
        line = self.lines.find(table, key)
        dotted = ".".join((*table, key) if key is not None else table)
        where = f"line {line}" if line else "line ?"
        return ConfigError(f"{self.source}: {where}: key '{dotted}': {message}")

    def parse(self, default_name: str) -> Sweep:
        try:
            data = tomllib.loads(self.text)
        except tomllib.TOMLDecodeError as exc:
            raise self._syntax_error(exc) from None

        for key in data:
            if key not in _TOP_TABLES:
                raise self.error((), key, f"unknown table; expected one of {', '.join(_TOP_TABLES)}")
            if not isinstance(data[key], dict):
                raise self.error((), key, f"expected a table [{key}]")

        split = self._split(data)
        meta = data.get("sweep", {})
        ranking = self._ranking(meta)
        for key in meta:
            if key in ("split", "ranking"):
                continue
            if key not in _SWEEP_KEYS:
                raise self.error(("sweep",), key, f"unknown key; expected one of {', '.join(_SWEEP_KEYS)}")
            if not isinstance(meta[key], str):
                raise self.error(("sweep",), key, f"expected a string, got {meta[key]!r}")
        name = meta.get("name", default_name)
        description = meta.get("description", "")

        rooms = self._rooms(data.get("rooms", {}))
        self.psets = self._parameter_sets(data.get("parameter_sets", {}))
        fixed = {k: v for k, v in data.get("fixed", {}).items() if k != "split"}
        axes, enhancers = self._axes(data.get("axes", {}), fixed)
        n_conditions = math.prod(len(v) for v in axes.values())
        if n_conditions > MAX_CONDITIONS:  # counted from the axes' lengths: nothing is expanded yet
            raise self.error(("axes",), None, f"the axes expand to {n_conditions:,} conditions; at most "
                                              f"{MAX_CONDITIONS:,} in one sweep (split it into several)")
        for name_ in axes["room"]:
            if name_ is not None and name_ not in rooms:
                table = ("axes",) if "room" in data.get("axes", {}) else ("fixed",)
                raise self.error(table, "room", f"unknown room {name_!r}; define [rooms.{name_}]")
        if any(r > 0 for r in axes["rt60_s"]) and any(r is None for r in axes["room"]):
            table = ("axes",) if "rt60_s" in data.get("axes", {}) else ("fixed",)
            raise self.error(table, "rt60_s", "rt60_s > 0 needs a room: define [rooms.<name>] and set room")
        params = self._enhancer_params(data.get("enhancer_params", {}), enhancers)
        for system, (_, pset) in self.psets.items():
            if system not in enhancers:
                raise self.error(("parameter_sets",), system, f"system {system!r} is not in axes.enhancers")
            params[system] = dict(pset.params)
        self._check_sensor_keys(axes, data)
        self._check_distances(axes, data)

        sweep = Sweep(
            name=name,
            description=description,
            source=self.source,
            text=self.text,
            enhancers=enhancers,
            enhancer_params=params,
            axes=axes,
            rooms=rooms,
            split=split,
            ranking=ranking,
            parameter_sets=self.psets,
        )
        self._check_room_rt60(sweep, data)
        self._check_geometry(sweep, data)
        return sweep

    def _ranking(self, meta: dict) -> tuple[str, ...]:
        """``[sweep] ranking``: a non-empty list of :data:`RANKABLE_METRICS`, without repeats (() when absent)."""
        if "ranking" not in meta:
            return ()
        value = meta["ranking"]
        allowed = "a non-empty list of distinct metrics among " + ", ".join(repr(m) for m in RANKABLE_METRICS)
        if (not isinstance(value, list) or not value or len(set(map(str, value))) != len(value)
                or not all(isinstance(v, str) and v in RANKABLE_METRICS for v in value)):
            raise self.error(("sweep",), "ranking", f"expected {allowed}, got {value!r}")
        return tuple(value)

    def _split(self, data: dict) -> str:
        """The sweep's data split, from ``[sweep]`` or ``[fixed]`` (not both; never an axis)."""
        allowed = "one of " + ", ".join(repr(s) for s in SPLITS)
        if "split" in data.get("axes", {}):
            raise self.error(("axes",), "split", f"a sweep draws from one split: give split = {allowed} "
                                                  "in [sweep] or [fixed]")
        places = [t for t in ("sweep", "fixed") if "split" in data.get(t, {})]
        if len(places) == 2:
            raise self.error(("fixed",), "split", "is also given in [sweep]; give it once")
        if not places:
            return "all"
        value = data[places[0]]["split"]
        if not isinstance(value, str) or value not in SPLITS:
            raise self.error((places[0],), "split", f"expected {allowed}, got {value!r}")
        return value

    def _syntax_error(self, exc: Exception) -> ConfigError:
        line = getattr(exc, "lineno", None)
        if line is None:
            m = re.search(r"line (\d+)", str(exc))
            line = int(m.group(1)) if m else None
        msg = getattr(exc, "msg", str(exc))
        lines = self.lines.text_lines
        if line and msg.startswith("Unclosed"):
            # tomllib notices an unclosed [ or { where the next statement starts: point at the
            # line that opened it instead.
            for back in range(min(line, len(lines)), 0, -1):
                text = lines[back - 1].split("#")[0]
                if text.count("[") + text.count("{") > text.count("]") + text.count("}"):
                    line = back
                    break
        key = None
        if line and line <= len(lines):
            m = re.match(r"\s*([A-Za-z0-9_.\-\"']+)\s*=", lines[line - 1])
            if m:
                key = m.group(1).strip("\"'")
        what = f"key '{key}': " if key else ""
        return ConfigError(f"{self.source}: line {line or '?'}: {what}invalid TOML: {msg}")

    def _rooms(self, table: dict) -> dict[str, Room]:
        rooms = {}
        for name, spec in table.items():
            if not isinstance(spec, dict):
                raise self.error(("rooms",), name, "expected a table with dims_m and pair_center_m")
            where = ("rooms", name)
            for key in spec:
                if key not in _ROOM_KEYS:
                    raise self.error(where, key, f"unknown key; expected one of {', '.join(_ROOM_KEYS)}")
            for key in ("dims_m", "pair_center_m"):
                if key not in spec:
                    raise self.error((), f"rooms.{name}", f"missing key {key!r}")
            dims = self._triple(where, "dims_m", spec["dims_m"], positive=True)
            center = self._triple(where, "pair_center_m", spec["pair_center_m"], positive=False)
            if any(not (MIN_WALL_DISTANCE_M <= c <= d - MIN_WALL_DISTANCE_M) for c, d in zip(center, dims)):
                raise self.error(where, "pair_center_m", f"{list(center)} is not inside the room {list(dims)}")
            az = spec.get("axis_azimuth_deg", 0.0)
            try:
                az = _physical("azimuth_deg")(az)
            except ValueError as exc:
                raise self.error(where, "axis_azimuth_deg", f"expected {exc}, got {az!r}") from None
            rooms[name] = Room(name=name, dims_m=dims, pair_center_m=center, axis_azimuth_deg=az)
        return rooms

    def _triple(self, where, key, value, *, positive):
        check = _physical("room_dim_m") if positive else _finite
        if not isinstance(value, list) or len(value) != 3:
            raise self.error(where, key, f"expected a list of 3 numbers in m, got {value!r}")
        try:
            return tuple(check(v) for v in value)
        except ValueError as exc:
            raise self.error(where, key, f"expected 3 of {exc}, got {value!r}") from None

    def _axes(self, axes: dict, fixed: dict) -> tuple[dict[str, tuple], tuple[str, ...]]:
        values: dict[str, tuple] = {}
        for key, raw in axes.items():
            if key == "enhancers":
                continue
            param = _AXIS_ALIASES.get(key, key)
            if param not in PARAMETERS:
                raise self.error(("axes",), key, "unknown axis; expected one of " + _axis_names())
            if not isinstance(raw, list) or not raw:
                raise self.error(("axes",), key, f"expected a non-empty list, got {raw!r}")
            checked = []
            for v in raw:
                try:
                    checked.append(PARAMETERS[param].check(v))
                except ValueError as exc:
                    raise self.error(("axes",), key, f"expected each value to be {exc}, got {v!r}") from None
            if len(set(checked)) != len(checked):
                raise self.error(("axes",), key, f"repeated values in {raw!r}")
            values[param] = tuple(checked)
        for key, raw in fixed.items():
            param = _AXIS_ALIASES.get(key, key)
            if param not in PARAMETERS:
                raise self.error(("fixed",), key, "unknown key; expected one of " + ", ".join(PARAMETERS))
            if param in values:
                raise self.error(("fixed",), key, "is also an axis; give it in [axes] or [fixed], not both")
            try:
                values[param] = (PARAMETERS[param].check(raw),)
            except ValueError as exc:
                raise self.error(("fixed",), key, f"expected {exc}, got {raw!r}") from None
        for param, spec in PARAMETERS.items():
            if param not in values:
                if spec.default is _REQUIRED:
                    raise self.error(("axes",), param, f"missing: give the {spec.doc} in [axes] or [fixed]")
                values[param] = (spec.default,)

        if "enhancers" not in axes:
            raise self.error(("axes",), "enhancers", "missing: list the enhancers to run")
        enh = axes["enhancers"]
        if not isinstance(enh, list) or not enh or not all(isinstance(e, str) and e for e in enh):
            raise self.error(("axes",), "enhancers", f"expected a non-empty list of names, got {enh!r}")
        if len(set(enh)) != len(enh):
            raise self.error(("axes",), "enhancers", f"repeated names in {enh!r}")
        known = _available_enhancers()
        for e in (e for e in enh if e not in self.psets):
            if e.split("@")[0] not in known:
                raise self.error(("axes",), "enhancers", f"unknown enhancer {e!r}; available: {', '.join(known)}")
            try:  # a known name with an unknown version (eb@99)
                _enhancer_spec(e)
            except ScenesimError as exc:
                raise self.error(("axes",), "enhancers", str(exc)) from None
        return values, tuple(enh)

    def _enhancer_params(self, table: dict, enhancers: Sequence[str]) -> dict[str, dict]:
        out = {}
        for name, params in table.items():
            if name not in enhancers:
                raise self.error(("enhancer_params",), name, f"enhancer {name!r} is not in axes.enhancers")
            if not isinstance(params, dict):
                raise self.error(("enhancer_params",), name, "expected a table of parameter = value")
            if name in self.psets:
                raise self.error(("enhancer_params",), name, f"system {name!r} takes its parameters from "
                                 "its parameter set ([parameter_sets]); edit that file or name another")
            try:
                _check_enhancer_params(name, params)
            except ParameterError as exc:
                if exc.name in params:
                    raise self.error(("enhancer_params", name), exc.name, str(exc)) from None
                raise self.error(("enhancer_params",), name, str(exc)) from None
            out[name] = dict(params)
        return out

    def _parameter_sets(self, table: dict) -> dict[str, tuple[str, ParameterSet]]:
        """``[parameter_sets]``: a system name of its own = the path of a ``params.toml``."""
        known = set(_available_enhancers())
        out = {}
        for name, value in table.items():
            if not isinstance(value, str) or not value:
                raise self.error(("parameter_sets",), name, f"expected the path of a params.toml, got {value!r}")
            if name.split("@")[0] in known or "@" in name:
                raise self.error(("parameter_sets",), name, "a tuned system needs a name of its own, without '@' "
                                 "and not a registered enhancer's")
            path = Path(value)
            if not path.is_absolute() and Path(self.source).is_file():
                path = Path(self.source).parent / path
            try:
                pset = load_parameter_set(path)
                _check_enhancer_params(pset.enhancer, dict(pset.params))
            except ScenesimError as exc:
                raise self.error(("parameter_sets",), name, str(exc)) from None
            out[name] = (str(path.resolve()), pset)
        return out

    def _table_of(self, key: str, data: dict) -> tuple[str, ...]:
        return ("axes",) if key in data.get("axes", {}) else ("fixed",)

    def _check_sensor_keys(self, axes: Mapping[str, tuple], data: dict) -> None:
        """Cross-key checks: a field for every noise; bands below Nyquist (high-pass corners are
        capped at 2 kHz by their own check, below every supported fs/2)."""
        for value in axes["noise_field"]:
            if isinstance(value, tuple):
                missing = sorted(set(axes["noise"]) - {k for k, _ in value})
                if missing:
                    raise self.error(
                        self._table_of("noise_field", data),
                        "noise_field",
                        f"no field for noise {', '.join(map(repr, missing))}; add it to the table",
                    )
        for band in axes["snr_band_hz"]:
            try:
                if band is not None:
                    check_snr_band("snr_band_hz", band, min(axes["fs"]))
            except ParameterError as exc:
                raise self.error(self._table_of("snr_band_hz", data), "snr_band_hz",
                                 f"expected {exc.allowed}, got {list(band)}") from None

    def _check_distances(self, axes: Mapping[str, tuple], data: dict) -> None:
        """Every talker/noise distance (and drawn range) keeps the source outside the mic pair."""
        spacing = max(axes["spacing_m"])
        for key in ("distance_m", "noise_distance_m"):
            range_key = _RANGE_KEYS.get(key)
            for dist in _with_range(axes[key], axes.get(range_key), 2):
                try:
                    check_outside_pair(key, dist, spacing)
                except ParameterError as exc:
                    shown = range_key if dist not in axes[key] else key
                    raise self.error(self._table_of(shown, data), shown,
                                     f"expected {exc.allowed} (spacing_m), got {dist:g}") from None

    def _check_room_rt60(self, sweep: Sweep, data: dict) -> None:
        """Each room can reach each RT60: Sabine absorption <= 1 (the rule ShoeBox applies to every method)."""
        from scenesim.room.rt60 import sabine_absorption

        for room in sweep.rooms.values():
            if room.name not in sweep.axes["room"]:
                continue
            for rt60 in sweep.axes["rt60_s"]:
                try:
                    if rt60 > 0:
                        sabine_absorption(rt60, room.dims_m)
                except ParameterError as exc:
                    raise self.error(self._table_of("rt60_s", data), "rt60_s",
                                     f"room {room.name!r} {list(room.dims_m)} m cannot have RT60 {rt60:g} s: "
                                     f"expected {exc.allowed}") from None

    def _check_geometry(self, sweep: Sweep, data: dict) -> None:
        """Every source must lie inside its room (the image-source method needs it)."""
        from scenesim.scene.geometry import MicPair

        for room in sweep.rooms.values():
            if room.name not in sweep.axes["room"]:
                continue
            pair = MicPair(room.pair_center_m, spacing_m=sweep.axes["spacing_m"][0], axis_azimuth_deg=room.axis_azimuth_deg)
            for dist_key, az_key in (("distance_m", "speech_az_deg"), ("noise_distance_m", "noise_az_deg")):
                for dist in _with_range(sweep.axes[dist_key], sweep.axes.get(_RANGE_KEYS.get(dist_key)), 2):
                    for az in _with_range(sweep.axes[az_key], sweep.axes.get(_RANGE_KEYS.get(az_key)), 13):
                        pos = pair.source_position(az, dist)
                        if any(not (MIN_WALL_DISTANCE_M <= p <= d - MIN_WALL_DISTANCE_M) for p, d in zip(pos, room.dims_m)):
                            table = ("axes",) if dist_key in data.get("axes", {}) else ("fixed",)
                            raise self.error(
                                table,
                                dist_key,
                                f"a source at {dist:g} m, {az:g} deg from the pair lies outside room "
                                f"{room.name!r} {list(room.dims_m)} m",
                            )


#: Parameters drawn per seed from a range key (the range's values are checked against rooms too).
_RANGE_KEYS = {"distance_m": "distance_range_m", "speech_az_deg": "speech_az_range_deg", "noise_az_deg": "noise_az_range_deg"}


def _with_range(values, ranges, n: int) -> tuple:
    """``values`` plus ``n`` points across each ``[lo, hi]`` of ``ranges`` (None entries skipped)."""
    out = list(values)
    for r in ranges or ():
        if r is not None:
            out.extend(np.linspace(r[0], r[1], n).tolist())
    return tuple(out)


def _axis_names() -> str:
    names = ["enhancers"] + [k for k, v in _AXIS_ALIASES.items()] + [p for p in PARAMETERS if p not in _AXIS_ALIASES.values()]
    return ", ".join(names)


def _available_enhancers() -> list[str]:
    from enhancers.core.registry import available

    return list(available())


def _enhancer_spec(name: str):
    from enhancers.core.registry import get_spec

    return get_spec(name)


def _check_enhancer_params(name: str, params: dict) -> None:
    from enhancers.core.registry import make

    make(name, **params)


class _KeyLines:
    """Line numbers of keys in TOML text, found by scanning (tomllib keeps no positions).

    Understands ``[table]`` headers, ``key = value`` lines and dotted keys; good enough for
    pointing a user at the line of an error.
    """

    _HEADER = re.compile(r"^\s*\[\s*([^\[\]]+?)\s*\]\s*(#.*)?$")
    _KEY = re.compile(r"^\s*([A-Za-z0-9_\-.\"' ]+?)\s*=")

    def __init__(self, text: str):
        self.text_lines = text.splitlines()
        self.keys: dict[tuple[str, ...], int] = {}
        self.headers: dict[tuple[str, ...], int] = {}
        table: tuple[str, ...] = ()
        for number, line in enumerate(self.text_lines, start=1):
            m = self._HEADER.match(line)
            if m:
                table = _split_key(m.group(1))
                self.headers.setdefault(table, number)
                continue
            m = self._KEY.match(line)
            if m:
                self.keys.setdefault((*table, *_split_key(m.group(1))), number)

    def find(self, table: tuple[str, ...], key: str | None) -> int | None:
        if key is not None:
            path = (*table, *_split_key(key))
            if path in self.keys:
                return self.keys[path]
            if path in self.headers:
                return self.headers[path]
            # a key at top level written as a dotted key or an inline table
            for known, number in self.keys.items():
                if known[-1:] == path[-1:]:
                    return number
        return self.headers.get(table)


def _split_key(text: str) -> tuple[str, ...]:
    return tuple(part.strip().strip("\"'") for part in text.split("."))
