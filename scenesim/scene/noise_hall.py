"""Machines in a reverberant factory hall: the ``"hall"`` noise field.

The ``phone`` preset's first factory is one machine as an anechoic plane wave -- the one noise a
first-order differential pair can null completely, so its SNR-I is an upper bound.  A real
factory has several machines in a hall whose reverberation reaches the phone from every
direction.  This field renders that: ``n_sources`` point sources (each playing its own excerpt of
the noise) at seeded places in a shoe-box hall of :data:`HALL_DIMS_M` with a reverberation time
of :data:`HALL_RT60_S`, heard by the scene's mic pair placed at :data:`HALL_PAIR_M` (same spacing
and axis azimuth).  The hall is the noise's own room: the scene's room (or free field) still
carries the talker, who is close to the phone.

Room impulse responses come from the hybrid renderer (``method="hybrid"``: exact images up to the
mixing time, a matched diffuse tail after it, :mod:`scenesim.room.hybrid`), cached on disk like every
RIR, so a 1-s hall costs a few seconds per machine once.
"""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from scenesim.room.cache import cached_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS, MicPair

__all__ = ["HALL_DIMS_M", "HALL_PAIR_M", "HALL_RT60_S", "hall_noise", "hall_positions"]

HALL_DIMS_M = (20.0, 12.0, 5.0)
"""The hall (m): a small production hall."""
HALL_RT60_S = 1.0
"""Its reverberation time (s), Sabine; industrial halls measure 1-2 s."""
HALL_PAIR_M = (12.0, 5.0, 1.2)
"""Where the phone is in the hall (m): off centre, at hand height."""
HALL_MIN_DISTANCE_M = 3.0
"""Machines stand at least this far from the phone (m) ..."""
HALL_WALL_MARGIN_M = 0.5
"""... and this far from the walls (m); their sound centres are 0.5-2 m above the floor."""


def hall_positions(seed: int, n_sources: int) -> np.ndarray:
    """Seeded machine positions ``(n_sources, 3)`` (m) in the hall.

    >>> p = hall_positions(0, 4)
    >>> p.shape, bool(np.all(np.linalg.norm(p - np.array(HALL_PAIR_M), axis=1) >= HALL_MIN_DISTANCE_M))
    ((4, 3), True)
    """
    rng = np.random.default_rng([seed, 0x4A11])
    lo = np.array([HALL_WALL_MARGIN_M, HALL_WALL_MARGIN_M, 0.5])
    hi = np.array([HALL_DIMS_M[0] - HALL_WALL_MARGIN_M, HALL_DIMS_M[1] - HALL_WALL_MARGIN_M, 2.0])
    out = []
    while len(out) < n_sources:  # the allowed region is most of the hall: a few redraws at most
        p = rng.uniform(lo, hi)
        if np.linalg.norm(p - np.asarray(HALL_PAIR_M)) >= HALL_MIN_DISTANCE_M:
            out.append(p)
    return np.asarray(out)


def hall_noise(signals: np.ndarray, pair: MicPair, *, fs: int, seed: int,
               c: float = SPEED_OF_SOUND_MPS) -> np.ndarray:
    """Image ``(2, n)`` of the machines playing ``signals`` ``(n_sources, n)`` in the hall.

    ``pair``'s spacing and axis azimuth are kept, its centre moves to :data:`HALL_PAIR_M`;
    ``seed`` places the machines (:func:`hall_positions`).  Each machine's image is its signal
    convolved with its hybrid RIR (cut to ``n`` samples).
    """
    signals = np.atleast_2d(np.asarray(signals, dtype=float))
    n = signals.shape[1]
    hall = ShoeBox(HALL_DIMS_M, rt60_s=HALL_RT60_S, c=c)
    mics = MicPair(HALL_PAIR_M, spacing_m=pair.spacing_m, axis_azimuth_deg=pair.axis_azimuth_deg).positions_m
    img = np.zeros((2, n))
    for sig, p in zip(signals, hall_positions(seed, signals.shape[0])):
        h = cached_rir(hall, tuple(p), mics, fs=fs, method="hybrid")
        img += sps.oaconvolve(sig[None, :], h, mode="full", axes=1)[:, :n]
    return img
