"""The worker side of a sweep: one condition -> its results rows (a pure function of the task).

A condition (scene x noise x SNR x seed) and the enhancers still missing for it is a
:class:`ConditionTask`; :func:`run_condition` is a pure function of it (condition, enhancer
specs, data directory) -> rows, so any executor (a local pool, Dask) gives the same numbers.
Inside a worker process the rendered scene of a geometry group (everything but the SNR) is
kept in a small cache, so a group is rendered once and only re-mixed per SNR; input metrics
are computed once per mixture, then each enhancer is run and measured.  The driver
(:mod:`benchmarks.run.runner`) plans the tasks and writes the rows.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import socket
import time
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np

from benchmarks.excinfo import exc_text as _exc_text
from benchmarks.run.sweep import Condition
from benchmarks.store.sqlite import package_versions
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS

# Condition columns every row of a unit carries (the store's names).
_CONDITION_COLUMNS = (
    "noise",
    "rt60_s",
    "speech_az_deg",
    "noise_az_deg",
    "seed",
    "room",
    "distance_m",
    "noise_distance_m",
    "noise_field",
    "fs",
    "duration_s",
    "far_field",
    "spacing_m",
    "wind_speed_mps",
    "split",
)


@dataclass(frozen=True)
class EnhancerSpec:
    """What a worker needs to build one enhancer: the sweep's name for it, its params, and the
    registry name that builds it when that differs (a ``[parameter_sets]`` system; "": ``name``)."""

    name: str
    params_json: str = "{}"
    enhancer: str = ""

    @property
    def params(self) -> dict[str, Any]:
        return json.loads(self.params_json)


@dataclass(frozen=True)
class ConditionTask:
    """One condition and the enhancers still to run on it (picklable, small)."""

    condition_json: str
    enhancers: tuple[EnhancerSpec, ...]
    data_dir: str | None = None
    #: Return the condition's clips for the listening page with its rows (:mod:`benchmarks.run.listen`).
    save_audio: bool = False

    @property
    def condition(self) -> Condition:
        return Condition.from_json(self.condition_json)


@dataclass(frozen=True)
class UnitTask:
    """One unit of work for an executor: one condition, or every condition of a geometry group."""

    conditions: tuple[ConditionTask, ...]

    def __len__(self) -> int:
        return len(self.conditions)



_DATASETS: dict[tuple[str | None, int, str], Any] = {}
_IMAGES: OrderedDict[tuple, Any] = OrderedDict()
_IMAGES_MAX = 2  # a worker interleaves at most a couple of geometry groups


def _dataset(data_dir: str | None, fs: int, split: str = "all"):
    key = (data_dir, fs, split)
    if key not in _DATASETS:
        from data_recipes import open_data

        _DATASETS[key] = open_data(data_dir, fs=fs, split=split)
    return _DATASETS[key]


def build_sensors(cond: Condition):
    """The condition's sensors: nominal mismatch and self-noise, this seed's production draw.

    None for the thesis' ideal sensors (identical noiseless mics).
    """
    from scenesim.scene.sensors import SensorModel, SensorTolerance

    if cond.ideal_sensors:
        return None
    nominal = SensorModel.from_mismatch(
        gain_db=cond.mic_gain_db,
        phase_deg=cond.mic_phase_deg,
        highpass_hz=cond.mic_highpass_hz,
        self_noise_dba=cond.self_noise_dba,
        speech_spl_db=cond.speech_spl_db,
    )
    tolerance = SensorTolerance(
        gain_tol_db=cond.mic_gain_tol_db,
        phase_tol_deg=cond.mic_phase_tol_deg,
        highpass_tol_hz=cond.mic_highpass_tol_hz,
    )
    return tolerance.draw(nominal, seed=cond.seed)


def sensor_columns(cond: Condition) -> dict[str, Any]:
    """The sensor parameters a row was computed with (drawn values, not the nominal ones)."""
    from scenesim.scene.sensors import SensorModel

    sensors = build_sensors(cond)
    out = (sensors or SensorModel()).describe()
    out["ideal_sensors"] = int(sensors is None)
    out["snr_band_lo_hz"], out["snr_band_hi_hz"] = cond.snr_band_hz or (None, None)
    return out


def build_scene(cond: Condition):
    """The :class:`scenesim.scene.compose.Scene` of a condition (same for every SNR of its group)."""
    from scenesim.room.shoebox import ShoeBox
    from scenesim.scene.compose import NoiseSource, Scene, SourcePlacement
    from scenesim.scene.geometry import MicPair
    from scenesim.scene.thesis_farfield import ThesisFarField

    thesis_model = None
    if cond.far_field_method == "thesis":
        thesis_model = ThesisFarField(fd_taps=cond.fd_taps, fd_window=cond.fd_window, azimuth_from=cond.azimuth_from)
    room = None
    if cond.room_dims_m is not None:
        from scenesim.room.scattering import DEFAULT_SCATTERING

        # Calibrated rooms are furnished rooms: diffuse wall scattering, fitted with it (issue 18).
        scattering = DEFAULT_SCATTERING if cond.rt60_method == "calibrated" else None
        room = ShoeBox(cond.room_dims_m, rt60_s=cond.rt60_s, rt60_method=cond.rt60_method, scattering=scattering)
    placed = {}  # fields have no place: keep NoiseSource's defaults
    if cond.noise_az_deg is not None:
        placed["azimuth_deg"] = cond.noise_az_deg
    if cond.noise_distance_m is not None:
        placed["distance_m"] = cond.noise_distance_m
    return Scene(
        fs=cond.fs,
        pair=MicPair(cond.pair_center_m, spacing_m=cond.spacing_m, axis_azimuth_deg=cond.axis_azimuth_deg),
        room=room,
        speech=SourcePlacement(azimuth_deg=cond.speech_az_deg, distance_m=cond.distance_m),
        noises=(NoiseSource(field=cond.noise_field, wind_speed_mps=cond.wind_speed_mps, **placed),),
        snr_db=cond.snr_db,
        far_field=cond.far_field,
        snr_mode=cond.snr_mode,
        reference=cond.reference,
        seed=cond.seed,
        sensors=build_sensors(cond),
        snr_band_hz=cond.snr_band_hz,
        thesis_far_field=thesis_model,
    )


def _noise_channels(field_type: str) -> int:
    # Diffuse, incoherent and wind fields are built from two independent noise channels;
    # point, spread and hall sources from one recording (spread, hall: disjoint excerpts of it).
    return 1 if field_type in ("point", "spread", "hall") else 2


def render_group(cond: Condition, data_dir: str | None):
    """``(SceneImages, speech_source, noise_source)`` of a condition's geometry group (cached)."""
    key = (data_dir, cond.group_id)
    if key in _IMAGES:
        _IMAGES.move_to_end(key)
        return _IMAGES[key]
    from scenesim.scene.compose import render_images

    ds = _dataset(data_dir, cond.fs, cond.split)
    speech = ds.speech(cond.duration_s, seed=cond.seed)
    noise = ds.noise(cond.noise, cond.duration_s, seed=cond.seed, n_channels=_noise_channels(cond.noise_field))
    images = render_images(build_scene(cond), _mono(speech.signal), [_squeeze(noise.signal)])
    value = (images, str(speech.source), str(noise.source))
    _PARTS[key] = _speech_parts(cond, images, _mono(speech.signal))
    _FILES[key] = {"speech_files": list(speech.files), "noise_files": list(noise.files)}
    _IMAGES[key] = value
    while len(_IMAGES) > _IMAGES_MAX:
        old = _IMAGES.popitem(last=False)[0]
        _PARTS.pop(old, None)
        _FILES.pop(old, None)
    return value


_PARTS: dict[tuple, Any] = {}  # (speech parts, acoustics columns) beside each cached group
_FILES: dict[tuple, dict[str, list[str]]] = {}  # the files (or seeds) each cached group's clips came from


def group_files(cond: Condition, data_dir: str | None) -> dict[str, list[str]]:
    """``{"speech_files": [...], "noise_files": [...]}``: what a condition's clips were cut from
    (files with ``[a:b]`` segments and ``@offset``, or generator seeds; :attr:`data_recipes.source.Clip.files`)."""
    render_group(cond, data_dir)
    return _FILES[(data_dir, cond.group_id)]


def _speech_parts(cond: Condition, images, speech):
    """Speech parts and room acoustics of a group; None where reverberation is not studied
    (free field with a direct-path target: the thesis sweeps pay nothing for it)."""
    if cond.rt60_s == 0.0 and cond.reference == "direct":
        return None, {}
    from benchmarks.metrics.reverb import acoustics_columns
    from scenesim.room.reverb_parts import speech_parts

    parts = speech_parts(images, speech, early_window_s=cond.early_window_ms / 1000.0)
    return parts, acoustics_columns(images, parts, rt60_target_s=cond.rt60_s)


def group_parts(cond: Condition, data_dir: str | None):
    """``(SpeechParts or None, acoustics columns)`` of a condition's group (after :func:`render_group`)."""
    render_group(cond, data_dir)
    return _PARTS[(data_dir, cond.group_id)]


def _mono(x):
    import numpy as np

    x = np.asarray(x, dtype=np.float64)
    return x[0] if x.ndim == 2 else x


def _squeeze(x):
    import numpy as np

    x = np.asarray(x, dtype=np.float64)
    return x[0] if x.ndim == 2 and x.shape[0] == 1 else x


def build_enhancer(spec: EnhancerSpec, cond: Condition):
    """The enhancer of a spec, with the condition's array geometry when it needs one."""
    from enhancers.core.registry import make, with_geometry

    return with_geometry(make(spec.enhancer or spec.name, **spec.params), spacing_m=cond.spacing_m,
                         c_mps=SPEED_OF_SOUND_MPS)


def run_unit(unit: UnitTask) -> list[list[dict[str, Any]]]:
    """The rows of every condition of a unit (one list per condition, in the unit's order)."""
    return [run_condition(task) for task in unit.conditions]


def run_condition(task: ConditionTask) -> list[dict[str, Any]]:
    """Compute the rows of one condition: render (or reuse) the scene, mix, measure every enhancer.

    Never raises for a problem with the condition: a failure to render or to build an
    enhancer gives rows with ``status='error'`` and the reason in ``error``.
    """
    from benchmarks.metrics.evaluate import evaluate_enhancer, input_metrics

    cond = task.condition
    worker = f"{socket.gethostname()}:{os.getpid()}"
    base = {
        **_condition_columns(cond),
        "scenesim_version": _scenesim_version(),
        "worker": worker,
    }
    rows: list[dict[str, Any]] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            t0 = time.perf_counter()
            images, speech_source, noise_source = render_group(cond, task.data_dir)
            parts, acoustics = group_parts(cond, task.data_dir)
            rendered = mixed = images.mix(cond.snr_db)
            if parts is not None and parts.reverberant and cond.reference != "direct":
                # Target = direct + early (the sweep's early window) for every intrusive metric.
                rendered = dataclasses.replace(rendered, reference=parts.target[:1].copy())
            base.update(speech_source=speech_source, noise_source=noise_source, **acoustics,
                        **group_files(cond, task.data_dir))
            base["render_s"] = time.perf_counter() - t0
            inputs = input_metrics(rendered, speech_parts=parts, reference=cond.reference)
            inputs = {**inputs, **_optional_input_metrics(cond, rendered)}
        except Exception as exc:
            text = _exc_text(exc)
            return [{**base, "enhancer": s.name, "status": "error", "error": f"scene failed: {text}"} for s in task.enhancers]
        outputs = {}  # first output channel per system, for the listening page
        for spec in task.enhancers:
            row = dict(base)
            try:
                enhancer = build_enhancer(spec, cond)
                row["enhancer_spec"] = json.dumps(enhancer.spec, sort_keys=True, default=str)
                row["enhancer_version"] = str(enhancer.version)
                probe = _FirstOutput(enhancer) if cond.metrics or task.save_audio else enhancer
                row.update(evaluate_enhancer(probe, rendered, input_metrics=inputs, speech_parts=parts))
                _add_optional_output_metrics(row, cond, rendered, inputs, probe)
            except Exception as exc:
                row.update(status="error", error=f"enhancer failed: {_exc_text(exc)}")
            row["enhancer"] = spec.name  # the sweep's name for it (e.g. "eb@1"), not the class's
            rows.append(row)
            if task.save_audio and row.get("status") == "ok" and getattr(probe, "output0", None) is not None:
                outputs[spec.name] = probe.output0
    notes = sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    if notes:
        for row in rows:
            row["warnings"] = "\n".join(notes)
    if task.save_audio and rows:
        from benchmarks.run.listen import CLIPS_KEY, worker_clips

        # The reference as mixed (direct path), as the report's re-render gives it.
        rows[0][CLIPS_KEY] = worker_clips(cond.fs, mixed.reference, mixed.mixture, outputs)
    return rows


class _FirstOutput:
    """The enhancer, keeping the first output channel of its first ``process`` call (the mixture's).

    Lets an opted-in metric score the output ``evaluate_enhancer`` computed without running
    the enhancer again; every other attribute is the enhancer's own.
    """

    def __init__(self, enhancer):
        self._enhancer = enhancer
        self.output0 = None

    def __getattr__(self, name):
        return getattr(self._enhancer, name)

    def process(self, x, fs):
        result = self._enhancer.process(x, fs)
        if self.output0 is None:
            self.output0 = np.array(result.output[0], dtype=np.float64)
        return result


def _optional_input_metrics(cond: Condition, rendered) -> dict[str, Any]:
    """The opted-in metrics (sweep key ``metrics``) of the mixture at the reference mic."""
    if "dnsmos" not in cond.metrics:
        return {}
    from benchmarks.metrics import dnsmos

    try:
        return dnsmos.input_columns(np.asarray(rendered.mixture)[0], int(rendered.fs))
    except ImportError:
        return {"dnsmos_input_error": "dnsmos: not installed: pip install -e '.[dnsmos]'"}
    except Exception as exc:  # an optional metric never fails the condition
        return {"dnsmos_input_error": f"dnsmos_in: {_exc_text(exc)}"}


def _add_optional_output_metrics(row: dict[str, Any], cond: Condition, rendered, inputs, enhancer) -> None:
    """Add the opted-in metrics of the enhancer's first output channel (and the input ones) to ``row``."""
    if "dnsmos" not in cond.metrics:
        return
    from benchmarks.metrics import dnsmos

    errors = [e for e in (row.get("error"), inputs.get("dnsmos_input_error")) if e]
    row.update({k: v for k, v in inputs.items() if k in dnsmos.COLUMNS})
    missing = "not installed" in (inputs.get("dnsmos_input_error") or "")
    if row.get("status") == "ok" and enhancer.output0 is not None and not missing:
        try:
            row.update(dnsmos.output_columns(enhancer.output0, int(rendered.fs), enhancer.tags.latency_samples))
        except Exception as exc:
            errors.append(f"dnsmos: {_exc_text(exc)}")
    row["error"] = "; ".join(errors) or None


@functools.lru_cache(maxsize=1)
def _scenesim_version() -> str | None:
    return package_versions(("scenesim",))["scenesim"]


def _condition_columns(cond: Condition) -> dict[str, Any]:
    return {
        "condition_id": cond.id,
        "snr_in_db": cond.snr_db,
        **{c: getattr(cond, c) for c in _CONDITION_COLUMNS},
        **sensor_columns(cond),
        "group_id": cond.group_id,
        "condition_json": cond.to_json(),
    }
