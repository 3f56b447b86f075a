"""Cross-check of source directivity against pyroomacoustics' ``CardioidFamily``.

pyroomacoustics (0.10.1) evaluates ``p + (1 - p) cos(theta)`` per image at the emission
direction its C++ engine traces from the source, frequency independent.  We build the same
room (its high-pass off, its 40-sample delay and 4 pi scale removed, as
:mod:`scenesim.room.crosscheck`) and compare with our single-band
``Directivity.cardioid_family(p)`` at the same orientation.  The remaining difference is the
two renderers' fractional-delay kernels (pyroomacoustics: a 81-tap windowed sinc from a lookup
table, ours: the exact windowed sinc), ~2e-3 relative L2 for omni sources.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenesim.room.crosscheck import pyroomacoustics_rirs
from scenesim.room.directivity import Directivity
from scenesim.room.ism import image_source_rir
from scenesim.room.shoebox import ShoeBox


@dataclass(frozen=True)
class DirectivityCheck:
    """Agreement of a cardioid-family source: relative L2 per mic, ours vs pyroomacoustics,
    and how much the directivity changes the RIR (relative L2 directive vs omni, ours)."""

    p: float
    azimuth_deg: float
    elevation_deg: float
    rel_l2: tuple
    effect_rel_l2: tuple

    def to_dict(self) -> dict:
        return {
            "p": self.p, "azimuth_deg": self.azimuth_deg, "elevation_deg": self.elevation_deg,
            "rel_l2": list(self.rel_l2), "directivity_effect_rel_l2": list(self.effect_rel_l2),
        }


def pyroomacoustics_cardioid_rir(room: ShoeBox, source_m, mics_m, *, fs, max_order, p, azimuth_deg,
                                 elevation_deg):
    """pyroomacoustics' RIRs ``(n_mics, n)`` for a ``CardioidFamily(p)`` source, our convention."""
    from pyroomacoustics.directivities import CardioidFamily, DirectionVector

    orientation = DirectionVector(azimuth=azimuth_deg, colatitude=90.0 - elevation_deg, degrees=True)
    out, _ = pyroomacoustics_rirs(room, source_m, mics_m, fs=fs, max_order=max_order,
                                  directivity=CardioidFamily(orientation, p))
    return out


def compare_directivity_with_pyroomacoustics(
    room: ShoeBox, source_m, mics_m, *, fs: int, max_order: int, p: float = 0.5,
    azimuth_deg: float = 0.0, elevation_deg: float = 0.0,
) -> DirectivityCheck:
    """Relative L2 per mic of our cardioid-family RIR against pyroomacoustics' (same image set).

    Example
    -------
    >>> from scenesim.room.shoebox import ShoeBox
    >>> chk = compare_directivity_with_pyroomacoustics(  # doctest: +SKIP
    ...     ShoeBox((5, 4, 3), 0.3), (1, 1, 1.5), (3, 2, 1.5), fs=16000, max_order=6)
    """
    d = Directivity.cardioid_family(p, azimuth_deg=azimuth_deg, elevation_deg=elevation_deg)
    ours = image_source_rir(room, source_m, mics_m, fs=fs, max_order=max_order, directivity=d)
    omni = image_source_rir(room, source_m, mics_m, fs=fs, max_order=max_order)
    theirs = pyroomacoustics_cardioid_rir(
        room, source_m, mics_m, fs=fs, max_order=max_order, p=p, azimuth_deg=azimuth_deg,
        elevation_deg=elevation_deg,
    )
    n = min(ours.shape[1], theirs.shape[1])
    rel = tuple(
        float(np.linalg.norm(ours[m, :n] - theirs[m, :n]) / np.linalg.norm(theirs[m, :n]))
        for m in range(ours.shape[0])
    )
    effect = tuple(
        float(np.linalg.norm(ours[m] - omni[m]) / np.linalg.norm(omni[m])) for m in range(ours.shape[0])
    )
    return DirectivityCheck(float(p), float(azimuth_deg), float(elevation_deg), rel, effect)
