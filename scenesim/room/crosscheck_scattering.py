"""Scattered rooms against pyroomacoustics' ray tracing (its hybrid ISM + ray-traced simulator).

Both render the same shoebox with the same per-wall energy absorption and scattering
coefficients (one value per wall, every band); pyroomacoustics keeps its own split (ISM up to
``pra_max_order``, then rays with diffuse rain to a 0.5 m receiver sphere).  Compared per octave
at each mic: T30, EDT and C50 (:func:`scenesim.room.iso3382.room_parameters` on both RIRs, so the
analysis is identical).  Ray tracing is stochastic: expect a few % of T30 between runs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from scenesim.room.crosscheck import PRA_GLOBAL_DELAY, PRA_WALL_NAMES
from scenesim.room.iso3382 import room_parameters
from scenesim.room.render import room_rir
from scenesim.room.shoebox import ShoeBox

COMPARE_BANDS_HZ = (250.0, 500.0, 1000.0, 2000.0, 4000.0)
"""Octaves compared (125 Hz is left out: a few modes, and pyroomacoustics' 125 Hz band edge)."""


@dataclass(frozen=True)
class ScatteringCheck:
    """Per-octave T30/EDT (s) and C50 (dB) of mic 0, ours and pyroomacoustics' ray tracing."""

    bands_hz: tuple[float, ...]
    t30_ours_s: list[float]
    t30_theirs_s: list[float]
    edt_ours_s: list[float]
    edt_theirs_s: list[float]
    c50_ours_db: list[float]
    c50_theirs_db: list[float]

    def to_dict(self) -> dict:
        return asdict(self)


def pyroomacoustics_rt_rir(room: ShoeBox, source_m, mic_m, *, fs: int, pra_max_order: int = 3,
                           n_rays: int = 20000, seed: int = 0) -> np.ndarray:
    """pyroomacoustics' hybrid ISM + ray-traced RIR ``(n,)`` of one mic (our time origin, no high-pass).

    ``seed`` seeds pyroomacoustics' global generator (``pra.random.seed``): its rays are random.
    """
    import pyroomacoustics as pra

    pra.random.seed(seed)

    scat = room.scattering_table()
    materials = {name: pra.Material(energy_absorption=float(a), scattering=float(s))
                 for name, a, s in zip(PRA_WALL_NAMES, room.wall_absorption, scat)}
    previous = pra.constants.get("rir_hpf_enable")
    pra.constants.set("rir_hpf_enable", False)
    try:
        proom = pra.ShoeBox(list(room.dims_m), fs=fs, materials=materials, max_order=pra_max_order,
                            air_absorption=False, ray_tracing=True)
        proom.set_sound_speed(room.c)
        proom.set_ray_tracing(n_rays=n_rays, receiver_radius=0.5)
        proom.add_source(list(np.asarray(source_m, dtype=float)))
        proom.add_microphone_array(np.asarray(mic_m, dtype=float).reshape(3, 1))
        proom.compute_rir()
    finally:
        pra.constants.set("rir_hpf_enable", previous)
    return np.asarray(proom.rir[0][0], dtype=float)[PRA_GLOBAL_DELAY:] / (4.0 * np.pi)


def _params(h, fs, hd):
    p = room_parameters(h, fs, h_direct=hd, centers_hz=COMPARE_BANDS_HZ)
    octave_c50 = []
    from scenesim.room.bands import octave_filter
    from scenesim.room.iso3382 import clarity_db

    for fc in COMPARE_BANDS_HZ:
        octave_c50.append(clarity_db(octave_filter(h, fs, fc), fs, onset=p["onset_sample"]))
    return p, octave_c50


def compare_scattering_with_pyroomacoustics(room: ShoeBox, source_m, mics_m, *, fs: int,
                                            n_rays: int = 20000) -> ScatteringCheck:
    """Per-octave T30, EDT and C50 of mic 0: ours (the room's scattering model) vs pyroomacoustics' ray tracing.

    ``room`` is a flat room (no bands, no air): the comparison is of the scattering models.
    """
    mic = np.atleast_2d(np.asarray(mics_m, dtype=float))[0]
    theirs = pyroomacoustics_rt_rir(room, source_m, mic, fs=fs, n_rays=n_rays)
    ours = room_rir(room, source_m, mic, fs=fs, highpass_hz=None, length_s=max(theirs.size / fs, 0.1))[0]
    hd = room_rir(room, source_m, mic, fs=fs, highpass_hz=None, max_order=0, length_s=ours.size / fs)[0]
    a, ca = _params(ours, fs, hd)
    b, cb = _params(theirs, fs, hd)
    return ScatteringCheck(COMPARE_BANDS_HZ, a["t30_s"].tolist(), b["t30_s"].tolist(), a["edt_s"].tolist(),
                           b["edt_s"].tolist(), ca, cb)


__all__ = ["COMPARE_BANDS_HZ", "ScatteringCheck", "compare_scattering_with_pyroomacoustics", "pyroomacoustics_rt_rir"]
