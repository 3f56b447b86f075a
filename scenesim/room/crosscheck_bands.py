"""Cross-check octave-band materials and air absorption against pyroomacoustics 0.10.1.

The same room is built in pyroomacoustics with per-wall octave-band materials
(``Material(energy_absorption={"coeffs", "center_freqs"})``) and, with air, our ISO 9613-1
coefficients passed to ``set_air_absorption`` converted to its convention (amplitude
``exp(-m d / 2)``, so ``m = a_dB ln10 / 10``).  Alignment as :mod:`scenesim.room.crosscheck` (40-sample
global delay removed, ``/ 4 pi``, its 10 Hz high-pass off, same ``max_order``).

What differs by design: pyroomacoustics filters each band's RIR with its Antoni
energy-conserving octave bank (512 taps), we with the complementary zero-phase bank of
:mod:`scenesim.room.bands`; so the RIRs agree per octave (energy, T30) more closely than sample by
sample.  Figures reported: relative L2 of the whole RIR, octave energy difference (dB) and
octave T30 difference (relative) on mic 0, plus, for air, our coefficients against
pyroomacoustics' own coarse table (20 C / 30-50 % class etc.).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from scenesim.errors import ParameterError, ScenesimError
from scenesim.room.bands import octave_filter, octave_rt60
from scenesim.room.crosscheck import PRA_WALL_NAMES, pyroomacoustics_rirs
from scenesim.room.render import air_db_per_m, band_centers, room_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.validate import check_fs, check_int

NEPER_ENERGY_PER_DB = math.log(10.0) / 10.0
"""pyroomacoustics' air coefficient ``m`` (energy, 1/m) per dB/m of ours."""


@dataclass(frozen=True)
class BandCrossCheck:
    """Agreement with pyroomacoustics for a room with octave-band absorption and/or air.

    Attributes
    ----------
    bands_hz : tuple of float
    rel_l2 : tuple of float
        Per mic ``||ours - theirs|| / ||theirs||`` over the common length.
    band_energy_db : tuple of float
        Mic 0, per octave: ``10 log10(E_ours / E_theirs)`` after the same octave filter.
    t30_ours_s, t30_theirs_s : tuple of float
        Mic 0, per octave T30 (NaN where the decay is too short to fit).
    max_t30_rel_diff : float
        ``max |t30_ours / t30_theirs - 1|`` over the octaves measured.
    max_band_energy_db : float
    fs, max_order : int
    """

    bands_hz: tuple[float, ...]
    rel_l2: tuple[float, ...]
    band_energy_db: tuple[float, ...]
    t30_ours_s: tuple[float, ...]
    t30_theirs_s: tuple[float, ...]
    max_t30_rel_diff: float
    max_band_energy_db: float
    fs: int
    max_order: int

    def to_dict(self) -> dict:
        """JSON-ready numbers (tuples as lists)."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}


def _pra_bands(fs: int) -> tuple[float, ...]:
    n = math.floor(math.log2(fs / 125.0))
    return tuple(125.0 * 2.0**k for k in range(n))


def pyroomacoustics_band_rir(room: ShoeBox, source_m, mics_m, *, fs: int, max_order: int) -> np.ndarray:
    """pyroomacoustics' RIRs ``(n_mics, n)`` of a room with bands/air, aligned to our convention."""
    import pyroomacoustics as pra

    fs = check_fs(fs)
    centers = band_centers(room)
    pra_centers = _pra_bands(fs)
    if tuple(centers[: len(pra_centers)]) != pra_centers:
        raise ParameterError("room", room.bands_hz, f"octave bands {pra_centers} (pyroomacoustics' at {fs} Hz)")
    alpha = room.wall_absorption
    table = alpha if alpha.ndim == 2 else np.repeat(alpha[:, None], len(centers), axis=1)
    materials = {
        name: pra.Material(energy_absorption={"coeffs": [float(v) for v in table[w, : len(pra_centers)]],
                                              "center_freqs": list(pra_centers)})
        for w, name in enumerate(PRA_WALL_NAMES)
    }
    air = None
    if room.air is not None:
        air = air_db_per_m(room)[: len(pra_centers)] * NEPER_ENERGY_PER_DB
    out, _ = pyroomacoustics_rirs(room, source_m, mics_m, fs=fs, max_order=max_order, materials=materials,
                                  air_absorption=air)
    return out


def _t30(h, fs, fc) -> float:
    try:
        return float(octave_rt60(h, fs, (fc,))[0])
    except ScenesimError:
        return math.nan


def compare_bands_with_pyroomacoustics(room: ShoeBox, source_m, mics_m, *, fs: int,
                                       max_order: int) -> BandCrossCheck:
    """Render ``room`` (bands and/or air) both ways with the same image set and compare.

    Example: ``compare_bands_with_pyroomacoustics(room, src, mics, fs=16000, max_order=12).to_dict()``.
    """
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
    fs = check_fs(fs)
    max_order = check_int("max_order", max_order, minimum=0)
    theirs = pyroomacoustics_band_rir(room, source_m, mics_m, fs=fs, max_order=max_order)
    ours = room_rir(room, source_m, mics_m, fs=fs, max_order=max_order, length_s=theirs.shape[1] / fs,
                    highpass_hz=None)  # its high-pass is off too
    n = min(ours.shape[1], theirs.shape[1])
    ours, theirs = ours[:, :n], theirs[:, :n]
    rel = tuple(float(np.linalg.norm(o - t) / max(np.linalg.norm(t), 1e-300)) for o, t in zip(ours, theirs))
    centers = [fc for fc in _pra_bands(fs) if fc * math.sqrt(0.5) < 0.499 * fs]
    energy, t_o, t_t = [], [], []
    for fc in centers:
        bo, bt = octave_filter(ours[0], fs, fc), octave_filter(theirs[0], fs, fc)
        energy.append(float(10.0 * np.log10(np.sum(bo**2) / np.sum(bt**2))))
        t_o.append(_t30(ours[0], fs, fc))
        t_t.append(_t30(theirs[0], fs, fc))
    diffs = [abs(a / b - 1.0) for a, b in zip(t_o, t_t) if math.isfinite(a) and math.isfinite(b)]
    return BandCrossCheck(
        bands_hz=tuple(centers), rel_l2=rel, band_energy_db=tuple(energy), t30_ours_s=tuple(t_o),
        t30_theirs_s=tuple(t_t), max_t30_rel_diff=float(max(diffs)) if diffs else math.nan,
        max_band_energy_db=float(np.max(np.abs(energy))), fs=fs, max_order=max_order,
    )


def pyroomacoustics_air_table(temperature_c: float, humidity_pct: float) -> np.ndarray:
    """pyroomacoustics' own air coefficients (its coarse table) for these conditions, in dB/m,
    at 125 Hz..8 kHz."""
    import pyroomacoustics as pra

    physics = pra.parameters.Physics(temperature=temperature_c, humidity=humidity_pct)
    coeffs = np.asarray(physics.get_air_absorption()["coeffs"], dtype=float)
    return coeffs / NEPER_ENERGY_PER_DB


__all__ = [
    "BandCrossCheck",
    "NEPER_ENERGY_PER_DB",
    "compare_bands_with_pyroomacoustics",
    "pyroomacoustics_air_table",
    "pyroomacoustics_band_rir",
]
