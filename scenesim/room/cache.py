"""The room-impulse-response cache: :func:`cached_rir` memoises ``image_source_rir``.

The generic machinery (keys, memory LRU, atomic disk files) is :mod:`scenesim.memo`;
this module adds what is specific to the image-source method: the RIR key
(:func:`rir_key`, which includes the room's per-wall absorption, ``ism.ALGORITHM_VERSION``
and :data:`CACHE_FORMAT`) and the memoised call.  The generic names are re-exported here
so that ``scenesim.room.cache.cached_array`` keeps working.
"""

from __future__ import annotations

import numpy as np

from scenesim.memo import (  # noqa: F401  (re-exported: the public names of this module before the split)
    CACHE_FORMAT_ARRAY,
    ENV_VAR,
    MEMORY_ITEMS,
    _cache_dir,
    array_key,
    cached_array,
    canonical,
    clear_memory_cache,
    memory_cache_size,
    stable_hash,
)

# v2: room_rir (20 Hz high-pass, bands, air); v3: scattering (issue 18);
# v4: per-octave hybrid tail, float32 tail noise (issue 18)
CACHE_FORMAT = "scenesim-rir-v4"
"""Bumped when the cached quantity's definition changes, which invalidates old disk files."""


def rir_key(room, source_m, mics_m, *, fs: int, **kwargs) -> str:
    """The cache key of one RIR computation."""
    from scenesim.room import ism  # imported lazily: keeps this module importable on its own

    return stable_hash(
        {
            "format": CACHE_FORMAT,
            "ism_version": getattr(ism, "ALGORITHM_VERSION", None),
            "room": room,
            "source_m": np.asarray(source_m, dtype=float),
            "mics_m": np.asarray(mics_m, dtype=float),
            "fs": fs,
            "kwargs": kwargs,
        }
    )


def cached_rir(room, source_m, mics_m, *, fs: int, cache_dir=None, **kwargs) -> np.ndarray:
    """``room_rir(room, source_m, mics_m, fs=fs, **kwargs)`` memoised; returns a copy.

    :func:`scenesim.room.render.room_rir` is ``image_source_rir`` for flat rooms and renders rooms
    with octave-band absorption or air absorption band by band.

    Parameters
    ----------
    room : ShoeBox
    source_m : 3 floats
    mics_m : array (n_mics, 3)
    fs : int
    cache_dir : path, optional
        Disk cache directory; default ``$SCENESIM_CACHE`` (no disk cache when unset).
    **kwargs
        Passed to :func:`scenesim.room.ism.image_source_rir` (``max_order``, ``length_s``, ...).

    Returns
    -------
    ndarray (n_mics, n_taps)
    """
    from scenesim.room.render import room_rir  # flat rooms: exactly image_source_rir

    def compute() -> np.ndarray:
        return np.asarray(room_rir(room, source_m, mics_m, fs=fs, **kwargs), dtype=np.float64)

    return cached_array(rir_key(room, source_m, mics_m, fs=fs, **kwargs), compute, cache_dir=cache_dir)
