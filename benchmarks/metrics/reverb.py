"""Reverberation metrics that count reverberation once (issue 10).

The target is the direct path + early reflections (``scenesim.room.reverb_parts``); the late
reverberation is interference, like the noise.  Given the scene's speech parts
(direct / early / late images), this module adds to a results row:

* input (reference mic, channel 0), once per mixture: ``sinr_in_db`` (early speech over
  late speech + noise), ``drr_in_db`` (direct over early + late), ``c50_in_db`` (direct +
  early over late), ``srmr_in`` (non-intrusive, :mod:`benchmarks.metrics.srmr`, of the mixture);
* output, per enhancer, by replaying each part through the enhancer's frozen processing
  (``Result.replay``; linear, so the replayed parts sum to the replayed speech):
  ``sinr_out_db``, ``sinr_i_db = sinr_out_db - sinr_in_db`` (over the same aligned samples),
  ``drr_out_db``, ``c50_out_db``, ``srmr_out`` (of the output itself).  Black boxes
  (not replayable): ``sinr_out_db`` by phase inversion on target vs interference
  (``y1 = f(T + I)``, ``y2 = f(T - I)``, Hagerman & Olofsson 2004); their DRR/C50 of the
  output are left None (they would need two more runs per part);
* room acoustics of the condition's actual RIR at the reference mic and what theory
  expects (:func:`acoustics_columns`).

SRMR costs ~0.3 s per 5 s signal (benchmarks/perf/metrics_cost.py), so it is computed only
when the row's target is ``early`` (the reverberation presets) or the scene is a room.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from benchmarks.metrics import speech as M
from benchmarks.metrics.srmr import srmr

#: Per-mixture columns (also in every row).
REVERB_INPUT_COLUMNS: dict[str, str] = {
    "metric_target": "TEXT",
    "early_window_ms": "REAL",
    "sinr_in_db": "REAL",
    "drr_in_db": "REAL",
    "c50_in_db": "REAL",
    "srmr_in": "REAL",
}

#: Per-enhancer columns.
REVERB_OUTPUT_COLUMNS: dict[str, str] = {
    "sinr_out_db": "REAL",
    "sinr_i_db": "REAL",
    "drr_out_db": "REAL",
    "c50_out_db": "REAL",
    "srmr_out": "REAL",
}

#: Per-condition room acoustics (runner columns).
ACOUSTICS_COLUMNS: dict[str, str] = {
    "t30_s": "REAL",
    "edt_s": "REAL",
    "drr_rir_db": "REAL",
    "c50_rir_db": "REAL",
    "rt60_target_s": "REAL",
    "drr_rir_target_db": "REAL",
    "c50_rir_target_db": "REAL",
    "critical_distance_m": "REAL",
    # ISO 3382-1 (scenesim.room.iso3382), each beside the same quantity of the diffuse-field target
    "t_speech_s": "REAL",
    "edt_speech_s": "REAL",
    "t_mid_s": "REAL",
    "edt_mid_s": "REAL",
    "d50_rir": "REAL",
    "d50_rir_target": "REAL",
    "drr_win_rir_db": "REAL",
    "drr_win_rir_target_db": "REAL",
}


def target_label(reference: str, early_window_s: float, reverberant: bool) -> str:
    """``"direct"`` or ``"early50"`` (direct + first 50 ms): what the intrusive metrics compare with.

    By definition, so one sweep has one label: in free field (``reverberant`` False) the
    direct + early target is the direct path, all there is.
    """
    if reference == "direct":
        return "direct"
    return f"early{1000.0 * early_window_s:g}"


def _ratio_db(num, den) -> float:
    return M.snr_db(num, den)


def wants_srmr(parts, reference: str) -> bool:
    """SRMR only where reverberation is studied (it costs ~0.3 s per 5 s signal)."""
    return parts is not None and (parts.reverberant or reference != "direct")


def input_columns(rendered, parts, *, reference: str) -> dict[str, Any]:
    """The per-mixture reverberation columns (channel 0 of the input), or all None without parts."""
    out: dict[str, Any] = dict.fromkeys(REVERB_INPUT_COLUMNS)
    if parts is None:
        return out
    out["metric_target"] = target_label(reference, parts.early_window_s, parts.reverberant)
    out["early_window_ms"] = 1000.0 * parts.early_window_s
    noise0 = np.asarray(rendered.noise_image)[0]
    d, e, late = parts.direct[0], parts.early[0], parts.late[0]
    out["sinr_in_db"] = _ratio_db(d + e, late + noise0)
    if parts.reverberant:
        out["drr_in_db"] = _ratio_db(d, e + late)
        out["c50_in_db"] = _ratio_db(d + e, late)
    if wants_srmr(parts, reference):
        out["srmr_in"] = srmr(np.asarray(rendered.mixture)[0], int(rendered.fs))
    return out


def output_columns(enhancer, result, rendered, parts, *, channels: int, latency: int, srmr_in) -> dict[str, Any]:
    """Per-enhancer columns: the parts replayed (or phase inversion for black boxes)."""
    out: dict[str, Any] = dict.fromkeys(REVERB_OUTPUT_COLUMNS)
    if parts is None:
        return out
    pick = slice(0, channels)
    fs = int(rendered.fs)
    noise = np.asarray(rendered.noise_image, dtype=np.float64)[pick]
    ref = np.asarray(rendered.reference).reshape(-1)

    def al(x):
        return M.align(np.asarray(x, dtype=np.float64)[0], ref, latency_samples=latency)[0]

    y = al(result.output)
    m = y.size
    n0 = np.asarray(rendered.noise_image)[0][:m]
    sinr_in = _ratio_db(parts.target[0][:m], parts.late[0][:m] + n0)
    if enhancer.tags.replayable:
        d_o, e_o, l_o, n_o = (al(result.replay(x[pick])) for x in (parts.direct, parts.early, parts.late, noise))
        out["sinr_out_db"] = _ratio_db(d_o + e_o, l_o + n_o)
        if parts.reverberant:
            out["drr_out_db"] = _ratio_db(d_o, e_o + l_o)
            out["c50_out_db"] = _ratio_db(d_o + e_o, l_o)
    else:
        target = parts.target[pick]
        interference = parts.late[pick] + noise
        y2 = al(enhancer.process(target - interference, fs).output)
        out["sinr_out_db"] = _ratio_db(0.5 * (y + y2), 0.5 * (y - y2))
    out["sinr_i_db"] = out["sinr_out_db"] - sinr_in
    if srmr_in is not None:
        mix0 = np.asarray(rendered.mixture)[0]
        # A passthrough output is the scored input itself: reuse its SRMR (~0.2 s per 4 s).
        same = latency == 0 and y.size == mix0.size and np.array_equal(y, mix0)
        out["srmr_out"] = srmr_in if same else srmr(y, fs)
    return out


def theory_drr_c50_db(distance_m: float, critical_distance_m: float, rt60_s: float, early_window_s: float = 0.05) -> tuple[float, float]:
    """DRR and C50 (dB) of Sabine's diffuse-field theory at ``distance_m``.

    ``D / R = (r_c / r)^2``; C by :func:`scenesim.room.iso3382.diffuse_clarity_db` with the early
    window (reverberation taken from the direct arrival on).
    """
    from scenesim.room.iso3382 import diffuse_clarity_db

    dr_db = 20.0 * math.log10(critical_distance_m / distance_m)
    return dr_db, diffuse_clarity_db(distance_m, critical_distance_m, rt60_s, early_window_s)


def acoustics_columns(images, parts, *, rt60_target_s: float) -> dict[str, Any]:
    """Room acoustics of the speech RIR at the reference mic, and their targets (None in free field).

    ``t_speech_s`` (500 Hz-2 kHz octave T30 mean) is the quantity the calibration fits, so it
    is the one to set beside ``rt60_target_s``; ``t30_s`` / ``edt_s`` stay the broadband values.
    """
    from scenesim.room.cache import cached_rir
    from scenesim.room.iso3382 import diffuse_field_parameters, room_parameters
    from scenesim.room.reverb_parts import rir_acoustics

    out: dict[str, Any] = dict.fromkeys(ACOUSTICS_COLUMNS)
    scene = images.scene
    if parts is None or not parts.reverberant or scene.room is None:
        return out
    pos = scene.speech.position(scene.pair)
    h = images.rirs["speech"][0]
    hd = cached_rir(scene.room, pos, scene.pair.positions_m[:1], fs=scene.fs, max_order=0)[0]
    got = rir_acoustics(h, hd, fs=scene.fs, cut_sample=parts.cut_sample)
    out.update(t30_s=got["t30_s"], edt_s=got["edt_s"], drr_rir_db=got["drr_db"], c50_rir_db=got["c50_db"])
    iso = room_parameters(h, scene.fs, h_direct=hd, centers_hz=(500.0, 1000.0, 2000.0))
    for key in ("t_speech_s", "edt_speech_s", "t_mid_s", "edt_mid_s"):
        out[key] = None if math.isnan(iso[key]) else iso[key]
    out["d50_rir"], out["drr_win_rir_db"] = iso["d50"], iso["drr_windowed_db"]
    r0 = float(np.linalg.norm(np.asarray(scene.pair.positions_m[0]) - pos))
    want = diffuse_field_parameters(rt60_target_s, r0, float(np.prod(scene.room.dims_m)))
    out["rt60_target_s"] = rt60_target_s
    out["critical_distance_m"] = want["critical_distance_m"]
    out["drr_rir_target_db"], out["c50_rir_target_db"] = theory_drr_c50_db(
        r0, want["critical_distance_m"], rt60_target_s, parts.early_window_s)
    out["d50_rir_target"], out["drr_win_rir_target_db"] = want["d50"], want["drr_windowed_db"]
    return out


__all__ = [
    "ACOUSTICS_COLUMNS",
    "REVERB_INPUT_COLUMNS",
    "REVERB_OUTPUT_COLUMNS",
    "acoustics_columns",
    "input_columns",
    "output_columns",
    "target_label",
    "theory_drr_c50_db",
    "wants_srmr",
]
