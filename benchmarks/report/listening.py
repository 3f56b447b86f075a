"""Audio for the listening page: pick a few conditions, get their audio, write matched clips.

The conditions are those the sweep saved clips for when all their rows are ok
(:func:`benchmarks.run.listen.pick_conditions`); their clips, saved beside the store
(:func:`benchmarks.run.listen.load_clips`), are only encoded here.  A store without them (an
older sweep, clips of another run, other conditions asked for) is re-rendered: this module
re-renders the scene from the row's recorded ``condition_json`` with the runner's own functions
(:func:`benchmarks.run.worker.render_group`, :func:`benchmarks.run.worker.build_enhancer`, the
channel choice of :func:`benchmarks.metrics.evaluate._select_channels`), on the data directory
recorded in the store's ``runs`` table, with the enhancer params of the recorded sweep.
It then checks that the re-render is the stored one: the speech/noise sources must equal
the row's ``speech_source``/``noise_source`` and each rebuilt enhancer's spec must equal
the row's ``enhancer_spec``; otherwise the clip is left out and the page says why.

Loudness matching: every clip of a condition (clean reference at mic 0, mixture at mic 0,
each system's first output channel) is scaled to the same *active speech level*
(:func:`scenesim.scene.mixing.active_speech_power`, simplified ITU-T P.56 method B) of
:data:`TARGET_LEVEL_DBFS`; if a clip would then peak above :data:`PEAK_LIMIT`, every clip of
that condition is lowered by the same factor, so they stay matched.  Clips are written as
Ogg Vorbis (libsndfile >= 1.0.29) or else 16-bit WAV under ``report/audio/``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.run.listen import DEFAULT_LISTEN_COUNT, LISTEN_AXES, load_clips, pick_conditions
from scenesim.errors import ParameterError

AUDIO_DIRNAME = "audio"
#: Active speech level every clip is matched to (dB re full scale; P.56's usual -26 dBov).
TARGET_LEVEL_DBFS = -26.0
#: Largest absolute sample value allowed after matching (a common gain enforces it).
PEAK_LIMIT = 0.95


@dataclass(frozen=True)
class ListenOptions:
    """Which conditions get audio players on the page.

    Attributes
    ----------
    condition_ids : tuple of str
        Exactly these conditions (``condition_id`` of the store), in this order.  Empty:
        choose ``count`` conditions spread over the swept axes (:func:`choose_conditions`).
    count : int
        How many conditions to choose when ``condition_ids`` is empty (0: no audio).
    """

    condition_ids: tuple[str, ...] = ()
    count: int = DEFAULT_LISTEN_COUNT

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 0:
            raise ParameterError("count", self.count, "an integer >= 0")
        if isinstance(self.condition_ids, str):
            raise ParameterError("condition_ids", self.condition_ids, "a tuple of condition ids")
        object.__setattr__(self, "condition_ids", tuple(str(c) for c in self.condition_ids))


@dataclass(frozen=True)
class Clip:
    """One audio player: what it is, where its file is (relative to the page), its length."""

    label: str
    role: str  # "reference", "mixture" or "output"
    enhancer: str | None
    path: str | None
    duration_s: float | None
    gain_db: float | None = None
    note: str | None = None


@dataclass(frozen=True)
class ListenCondition:
    """The clips of one condition, its stored rows (metrics per enhancer), notes and what to listen for."""

    condition_id: str
    label: str
    clips: tuple[Clip, ...] = ()
    rows: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    hint: str = ""


@dataclass(frozen=True)
class Listening:
    """What the page's listening section shows: the conditions and general notes."""

    conditions: tuple[ListenCondition, ...] = ()
    notes: tuple[str, ...] = ()
    audio_format: str | None = None


class DataReproError(RuntimeError):
    """The recorded data cannot be re-rendered here (shown on the page, never raised out)."""


# -- choosing conditions -------------------------------------------------------------------


def choose_conditions(rows: Sequence[Mapping[str, Any]], *, count: int) -> list[str]:
    """``count`` condition ids spread over the swept axes that matter for listening
    (:data:`LISTEN_AXES`: RT60, talker distance, noise, input SNR; ok rows only), as
    :func:`benchmarks.run.listen.pick_conditions` chooses them: the conditions whose clips
    the sweep saved when every row is ok.

    >>> rows = [{"condition_id": f"{n}{s}", "noise": n, "snr_in_db": s, "seed": 0, "status": "ok"}
    ...         for n in ("wind", "babble") for s in (0, 5, 10)]
    >>> choose_conditions(rows, count=4)
    ['babble0', 'wind0', 'babble10', 'wind5']
    """
    ok = [r for r in rows if r.get("status") == "ok" and r.get("snr_in_db") is not None and r.get("condition_id")]
    return pick_conditions(ok, count=count)


def listen_for(row: Mapping[str, Any]) -> str:
    """What to listen for in a condition, from its parameters (one sentence).

    >>> listen_for({"noise": "wind", "snr_in_db": 0.0, "rt60_s": 0.0})
    'Listen for residual wind bursts and low-frequency rumble, and for lost syllables where the noise dominates.'
    """
    noise = str(row.get("noise") or "")
    hints = [_NOISE_HINTS.get(noise, f"what is left of the {noise} noise")]
    rt60 = row.get("rt60_s") or 0.0
    if rt60 and float(rt60) > 0:
        hints.insert(0, f"late reverberation after the onsets (RT60 {float(rt60):.1f} s): is the tail shortened or left")
    snr = row.get("snr_in_db")
    if snr is not None and float(snr) <= 5:
        hints.append("for lost syllables where the noise dominates")
    elif snr is not None and float(snr) >= 20:
        hints.append("for changes to the talker's timbre (little noise is left to remove)")
    return "Listen for " + ", and ".join(hints) + "."


_NOISE_HINTS = {
    "wind": "residual wind bursts and low-frequency rumble",
    "babble": "the competing talkers left behind, and musical noise (twittering tones) from spectral subtraction",
    "factory": "residual machine hum and tones, and musical noise from spectral subtraction",
}


# -- rendering -----------------------------------------------------------------------------


@contextlib.contextmanager
def _data_env(data_dir: str | None):
    """A run without a data directory used the built-in data: hide ``$SCENESIM_DATA``."""
    saved = os.environ.pop("SCENESIM_DATA", None) if data_dir is None else None
    try:
        yield
    finally:
        if saved is not None:
            os.environ["SCENESIM_DATA"] = saved


def _sweep_params(runs: Sequence[Mapping[str, Any]]) -> tuple[dict[str, dict], dict[str, str]]:
    """``(params, bases)`` per sweep name, from the recorded sweeps (later runs win): the enhancer
    params, and for a ``[parameter_sets]`` system the registered enhancer that builds it."""
    from benchmarks.run.sweep import parse_sweep

    params: dict[str, dict] = {}
    bases: dict[str, str] = {}
    for run in runs:
        try:
            sweep = parse_sweep(run.get("config_toml") or "", source=str(run.get("source")))
        except Exception:  # an unreadable old config (or a moved parameter set): the spec check says so
            continue
        for name in sweep.enhancers:
            params[name] = dict(sweep.enhancer_params.get(name, {}))
            if sweep.registered_name(name) != name:
                bases[name] = sweep.registered_name(name)
    return params, bases


def _same_spec(stored: str | None, built: Mapping[str, Any]) -> bool:
    if not stored:
        return False
    text = json.dumps(built, sort_keys=True, default=str)
    return json.loads(stored) == json.loads(text)


def render_condition(
    rows: Mapping[str, Mapping[str, Any]], *, data_dir: str | None, params: Mapping[str, dict],
    bases: Mapping[str, str] | None = None,
) -> tuple[dict[str, np.ndarray], int, list[str]]:
    """Re-render one condition; ``({label: mono signal}, fs, notes)``.

    ``rows`` maps enhancer name to its stored row (same condition); ``bases`` the registered
    enhancer of a ``[parameter_sets]`` system (its sweep name is not registered).  Labels are
    ``"reference"``, ``"mixture"`` and the enhancer names that could be reproduced;
    ``notes`` says what could not (a changed data source or enhancer spec).
    """
    from benchmarks.metrics.evaluate import _select_channels
    from benchmarks.run.sweep import Condition
    from benchmarks.run.worker import EnhancerSpec, build_enhancer, render_group

    first = next(iter(rows.values()))
    cond = Condition.from_json(first["condition_json"])
    notes: list[str] = []
    with _data_env(data_dir), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        images, speech_source, noise_source = render_group(cond, data_dir)
        rendered = images.mix(cond.snr_db)
    stored = (first.get("speech_source"), first.get("noise_source"))
    if (speech_source, noise_source) != stored:
        where = data_dir or "the built-in data"
        raise DataReproError(
            f"cannot reproduce this condition: the store recorded speech {stored[0]!r} and noise "
            f"{stored[1]!r}, but {where} now gives {speech_source!r} and {noise_source!r} "
            "(is the data directory missing or changed?)"
        )
    notes += sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    signals = {
        "reference": np.asarray(rendered.reference, dtype=np.float64)[0],
        "mixture": np.asarray(rendered.mixture, dtype=np.float64)[0],
    }
    for name, row in rows.items():
        spec = EnhancerSpec(name, json.dumps(params.get(name, {}), sort_keys=True), (bases or {}).get(name, ""))
        try:
            enhancer = build_enhancer(spec, cond)
            if not _same_spec(row.get("enhancer_spec"), enhancer.spec):
                notes.append(
                    f"{name}: not played, its stored spec differs from what this installation "
                    f"builds (stored {row.get('enhancer_spec')}, now {json.dumps(enhancer.spec, sort_keys=True)})"
                )
                continue
            x, _, _ = _select_channels(enhancer, rendered)
            signals[name] = np.asarray(enhancer.process(x, cond.fs).output, dtype=np.float64)[0]
        except Exception as exc:
            notes.append(f"{name}: not played, re-running it failed ({type(exc).__name__}: {exc})")
    return signals, cond.fs, notes


#: Bumped when :func:`render_condition`'s output changes for the same rows (cache key part).
LISTEN_CACHE_VERSION = 1


def render_condition_cached(
    rows: Mapping[str, Mapping[str, Any]], *, data_dir: str | None, params: Mapping[str, dict],
    bases: Mapping[str, str] | None = None,
) -> tuple[dict[str, np.ndarray], int, list[str]]:
    """:func:`render_condition` memoised (:func:`scenesim.memo.cached_array`, on disk in
    ``$SCENESIM_CACHE``): a report written again re-renders nothing.  Only fully reproduced
    conditions (no notes) are kept; the key holds every stored row, the data directory, the
    sweep's enhancer params and the scenesim version.
    """
    import scenesim
    from scenesim.memo import array_key, cached_array
    from scenesim.room import ism

    first = next(iter(rows.values()))
    from benchmarks.run.sweep import Condition

    fs = int(Condition.from_json(first["condition_json"]).fs)
    extra = {"bases": dict(bases)} if bases else {}  # keys of caches without tuned systems unchanged
    key = array_key("listening-signals", LISTEN_CACHE_VERSION, data_dir=data_dir, params=dict(params), **extra,
                    scenesim=scenesim.__version__, ism=getattr(ism, "ALGORITHM_VERSION", None),
                    rows={name: [r.get("condition_json"), r.get("enhancer_spec"), r.get("speech_source"),
                                 r.get("noise_source")] for name, r in rows.items()})
    labels = ["reference", "mixture", *rows]
    fresh: list = []

    def compute() -> np.ndarray:
        signals, fs_out, notes = render_condition(rows, data_dir=data_dir, params=params, bases=bases)
        fresh.append((signals, fs_out, notes))
        if notes or list(signals) != labels:
            return np.zeros((0, 0))  # not kept: an empty marker, recomputed next time
        return np.stack([signals[k] for k in labels])

    stacked = cached_array(key, compute)
    if fresh:
        return fresh[0]
    if stacked.shape[0] != len(labels):  # an incomplete condition: render again
        return render_condition(rows, data_dir=data_dir, params=params, bases=bases)
    return dict(zip(labels, stacked)), fs, []


def match_loudness(signals: Mapping[str, np.ndarray], fs: int) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Scale every signal to :data:`TARGET_LEVEL_DBFS` active level, then limit the common peak.

    Returns the scaled signals and each one's total gain in dB.  A silent signal is left
    at zero (gain 0 dB).

    >>> x = np.sin(np.arange(16000) / 5.0)
    >>> _, gains = match_loudness({"a": 0.1 * x, "b": 0.01 * x}, 16000)
    >>> round(gains["b"] - gains["a"], 6)
    20.0
    """
    from scenesim.scene.mixing import active_speech_power

    target = 10.0 ** (TARGET_LEVEL_DBFS / 10.0)
    gains: dict[str, float] = {}
    for name, x in signals.items():
        p = active_speech_power(x, fs) if np.any(x) else 0.0
        gains[name] = math.sqrt(target / p) if p > 0.0 else 1.0
    peak = max((float(np.max(np.abs(x))) * gains[n] for n, x in signals.items() if x.size), default=0.0)
    common = PEAK_LIMIT / peak if peak > PEAK_LIMIT else 1.0
    out = {n: x * gains[n] * common for n, x in signals.items()}
    return out, {n: 20.0 * math.log10(gains[n] * common) for n in signals}


def audio_format() -> tuple[str, str, str]:
    """``(extension, soundfile format, subtype)``: Ogg Vorbis when libsndfile has it, else WAV."""
    import soundfile as sf

    if "VORBIS" in sf.available_subtypes("OGG"):
        return "ogg", "OGG", "VORBIS"
    return "wav", "WAV", "PCM_16"


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def _write_clips(signals, fs, gains, cid, audio_dir, fmt) -> list[Clip]:
    import soundfile as sf

    ext, major, subtype = fmt
    clips = []
    for k, (name, x) in enumerate(signals.items()):
        path = audio_dir / f"{_safe(cid)}_{k:02d}_{_safe(name)}.{ext}"
        sf.write(str(path), np.clip(x, -1.0, 1.0), fs, format=major, subtype=subtype)
        role = name if name in ("reference", "mixture") else "output"
        label = {"reference": "clean reference (mic 0, direct path)", "mixture": "input mixture (mic 0)"}
        clips.append(
            Clip(
                label=label.get(name, name),
                role=role,
                enhancer=None if role != "output" else name,
                path=f"{AUDIO_DIRNAME}/{path.name}",
                duration_s=x.size / fs,
                gain_db=gains[name],
            )
        )
    return clips


def _label(row: Mapping[str, Any]) -> str:
    """The condition in words, geometry rounded (drawn azimuths and distances are not exact choices)."""
    from benchmarks.report.tables import num
    from benchmarks.run.sweep import Condition

    try:
        c = Condition.from_json(row["condition_json"])
    except Exception:
        return f"{row.get('noise')} {row.get('snr_in_db')} dB, seed {row.get('seed')}"
    room = "free field" if c.room_dims_m is None else f"{c.room} RT60 {c.rt60_s:.1f} s, talker {c.distance_m:.2f} m"
    naz = num(row.get("noise_az_deg"))
    where = f"noise {naz:.0f}°" if c.noise_field == "point" and naz is not None else f"{c.noise_field} noise"
    return f"{c.noise} {c.snr_db:g} dB, {room}, speech {c.speech_az_deg:.0f}°, {where}, seed {c.seed}"


def build_listening(
    rows: Sequence[Mapping[str, Any]], report_dir: Path, store_dir: Path, options: ListenOptions
) -> Listening:
    """Choose conditions, load their saved clips (else re-render them) and write the matched
    clips under ``report_dir/audio``.

    Never raises for a condition that cannot be reproduced: its notes say why.
    """
    audio_dir = Path(report_dir) / AUDIO_DIRNAME
    if audio_dir.is_dir():  # clips of an earlier report would be stale
        for old in audio_dir.glob("*"):
            if old.suffix in (".ogg", ".wav") and old.is_file():
                old.unlink()
    ids = list(options.condition_ids) or choose_conditions(rows, count=options.count)
    if not ids:
        return Listening(notes=("No conditions chosen for listening.",))
    store_path = Path(store_dir) / "results.sqlite"
    if not store_path.is_file():
        return Listening(notes=(f"No results store at {store_path}: audio cannot be re-rendered.",))
    from benchmarks.store.sqlite import ResultStore

    with ResultStore(store_path, readonly=True) as store:
        runs = store.runs()
    data_dir = runs[-1].get("data_dir") if runs else None
    params, bases = _sweep_params(runs)
    by_cond: dict[str, dict[str, Mapping[str, Any]]] = {}
    for r in rows:
        if r.get("status") == "ok" and r.get("condition_json"):
            by_cond.setdefault(str(r["condition_id"]), {})[str(r["enhancer"])] = r
    fmt = audio_format()
    audio_dir.mkdir(parents=True, exist_ok=True)
    out, n_saved = [], 0
    for cid in ids:
        crow = by_cond.get(cid)
        if not crow:
            out.append(ListenCondition(cid, cid, notes=("no 'ok' rows with this condition_id in the store",)))
            continue
        label = _label(next(iter(crow.values())))
        saved = load_clips(store_dir, crow)  # saved by the sweep: nothing to re-render
        try:
            signals, fs, notes = (*saved, []) if saved else render_condition_cached(crow, data_dir=data_dir, params=params,
                                                                                   bases=bases)
            n_saved += saved is not None
        except Exception as exc:
            out.append(ListenCondition(cid, label, rows=crow, notes=(f"{type(exc).__name__}: {exc}",)))
            continue
        same = [n for n in crow if n in signals and signals[n].shape == signals["mixture"].shape
                and np.array_equal(signals[n], signals["mixture"])]  # fmt: skip
        for name in same:
            del signals[name]
        notes = [*notes, *(f"{n}: identical to the input mixture, not repeated" for n in same)]
        scaled, gains = match_loudness(signals, fs)
        clips = _write_clips(scaled, fs, gains, cid, audio_dir, fmt)
        out.append(ListenCondition(cid, label, tuple(clips), crow, tuple(notes), listen_for(next(iter(crow.values())))))
    data = data_dir or "the built-in data (artificial voice, synthesized noise)"
    general = (
        f"Clips of {n_saved} condition(s) saved by the sweep, of {len(out) - n_saved} re-rendered from {data}."
        if n_saved else f"Data re-rendered from {data}.",
    )
    return Listening(tuple(out), general, f"{fmt[1]} {fmt[2]}")


__all__ = [
    "DEFAULT_LISTEN_COUNT",
    "LISTEN_AXES",
    "Clip",
    "ListenCondition",
    "ListenOptions",
    "Listening",
    "audio_format",
    "build_listening",
    "choose_conditions",
    "listen_for",
    "match_loudness",
    "render_condition",
    "render_condition_cached",
]
