"""``scenesim rir``'s ISO 3382-1 table: every parameter of each mic's RIR beside the same quantity of
the target (:mod:`scenesim.room.iso3382`).

The target reverberation time is the one the user asked for (``--rt60`` for every octave,
``--band-rt60`` per octave), else the room's Sabine value, labelled as such; C50, D50 and the
DRRs are Sabine's diffuse-field values at each mic's distance for the target's T_mid.
"""

from __future__ import annotations

import math

import numpy as np

from scenesim.room.bands import OCTAVE_CENTERS_HZ
from scenesim.room.iso3382 import TMID_BANDS_HZ, diffuse_field_parameters, room_parameters


def _target_per_octave(room, rt60_arg) -> tuple[np.ndarray, str]:
    """Target T per default octave and where it comes from."""
    n = len(OCTAVE_CENTERS_HZ)
    want = room.target_rt60_s if room.target_rt60_s is not None else rt60_arg
    source = "target"
    if want is None:
        want, source = room.sabine_rt60_s, "Sabine"
    t = np.asarray(want, dtype=float)
    if t.ndim == 0:
        return np.full(n, float(t)), source
    if room.bands_hz is not None and tuple(room.bands_hz) == tuple(OCTAVE_CENTERS_HZ):
        return t, source
    return np.full(n, float(np.mean(t))), source


def _fmt(v) -> str:
    return "    -  " if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:7.3f}"


def iso3382_table(h, h_direct, room, source_m, mics_m, *, fs: int, rt60_arg=None) -> dict:
    """Print the table for every mic; return it as JSON-able numbers (``rir.json["iso3382"]``)."""
    target_t, source = _target_per_octave(room, rt60_arg)
    mid = [OCTAVE_CENTERS_HZ.index(f) for f in TMID_BANDS_HZ]
    t_mid_target = float(np.mean(target_t[mid]))
    print(f"ISO 3382-1 parameters (achieved / {source}; C50, D50, DRR: Sabine diffuse field at T_mid "
          f"{t_mid_target:.3f} s):")
    print("  octave (Hz)      " + " ".join(f"{f:>7g}" for f in OCTAVE_CENTERS_HZ))
    print(f"  T30 {source:<12} " + " ".join(_fmt(float(v)) for v in target_t))
    out = {"target_source": source, "target_t30_s": target_t.tolist(), "mics": []}
    for m in range(h.shape[0]):
        got = room_parameters(h[m], fs, h_direct=h_direct[m])
        r = float(np.linalg.norm(np.asarray(mics_m[m], dtype=float) - np.asarray(source_m, dtype=float)))
        want = diffuse_field_parameters(t_mid_target, r, room.volume_m3)
        print(f"  mic {m} T30 (s)    " + " ".join(_fmt(float(v)) for v in got["t30_s"]))
        print(f"  mic {m} EDT (s)    " + " ".join(_fmt(float(v)) for v in got["edt_s"]))
        line = [f"T_mid {got['t_mid_s']:.3f}/{t_mid_target:.3f} s", f"EDT_mid {got['edt_mid_s']:.3f}/{t_mid_target:.3f} s"]
        for key, label, unit in (("c50_db", "C50", " dB"), ("d50", "D50", ""),
                                 ("drr_windowed_db", "DRR +-2.5 ms", " dB"), ("drr_exact_db", "DRR exact image", " dB")):
            line.append(f"{label} {got[key]:.2f}/{want[key]:.2f}{unit}")
        print(f"  mic {m} at {r:.2f} m: " + ", ".join(line))
        got_json = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in got.items()}
        out["mics"].append({"distance_m": r, "achieved": got_json, "diffuse_field": want})
    return out


__all__ = ["iso3382_table"]
