"""RIRs of any :class:`~scenesim.room.ShoeBox`: flat rooms by one image-source render, rooms with
octave-band absorption and/or air absorption band by band (issue 10).

For a room with ``bands_hz`` band ``b`` is rendered by :func:`scenesim.ism.image_source_rir`
with that band's wall reflection coefficients (:meth:`ShoeBox.band_room`); with ``air`` each
band's RIR is multiplied by ``10^(-a_b c t / 20)`` (:func:`scenesim.air.air_gain`, ``a_b`` at the
band's exact ISO midband frequency); the band RIRs are then combined through the
complementary zero-phase filter bank of :mod:`scenesim.bands`::

    h = sum_b  W_b * ( g_b(t) . h_b(t) )        (W_b sum to 1: identical h_b give h_b back)

A flat room with air is rendered once and split into the default octaves.  Bands above
Nyquist (zero weight) are skipped.
"""

from __future__ import annotations

import numpy as np

from scenesim.air import air_gain
from scenesim.bands import OCTAVE_CENTERS_HZ, active_bands, combine_bands, exact_midband_hz
from scenesim.errors import ParameterError
from scenesim.ism import default_length_s, image_source_rir
from scenesim.room import ShoeBox
from scenesim.validate import check_fs


def band_centers(room: ShoeBox) -> tuple[float, ...]:
    """The band centres a room is rendered in: ``room.bands_hz`` or the default octaves."""
    return room.bands_hz if room.bands_hz is not None else OCTAVE_CENTERS_HZ


def air_db_per_m(room: ShoeBox) -> np.ndarray:
    """ISO 9613-1 attenuation (dB/m) per rendering band of ``room`` (zeros without air)."""
    centers = band_centers(room)
    if room.air is None:
        return np.zeros(len(centers))
    return np.atleast_1d(room.air.db_per_m(exact_midband_hz(centers)))


def band_rirs(room: ShoeBox, source_m, mics_m, *, fs: int, length_s: float | None = None,
              **kwargs) -> np.ndarray:
    """Per-band RIRs ``(n_bands, n_mics, n_taps)`` before the filter bank (air gain applied).

    Bands above Nyquist are zeros.  ``kwargs`` go to :func:`scenesim.ism.image_source_rir`.
    """
    fs = check_fs(fs)
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.ShoeBox")
    centers = band_centers(room)
    if length_s is None and kwargs.get("max_order") is None:
        length_s = default_length_s(room, source_m, mics_m)
    active = active_bands(centers, fs)
    a_db = air_db_per_m(room)
    c = room.c if kwargs.get("c") is None else float(kwargs["c"])
    rendered: dict[int, np.ndarray] = {}
    if room.bands_hz is None:
        flat = image_source_rir(room.band_room(), source_m, mics_m, fs=fs, length_s=length_s, **kwargs)
        rendered = {b: flat for b in range(len(centers)) if active[b]}
    else:
        for b in range(len(centers)):
            if active[b]:
                rendered[b] = image_source_rir(room.band_room(b), source_m, mics_m, fs=fs,
                                               length_s=length_s, **kwargs)
    n_taps = max(h.shape[-1] for h in rendered.values())
    n_mics = next(iter(rendered.values())).shape[0]
    out = np.zeros((len(centers), n_mics, n_taps))
    for b, h in rendered.items():
        out[b, :, : h.shape[-1]] = h
        if a_db[b] > 0:
            out[b] *= air_gain(n_taps, fs, float(a_db[b]), c)
    return out


def room_rir(room: ShoeBox, source_m, mics_m, *, fs: int, **kwargs) -> np.ndarray:
    """RIRs ``(n_mics, n_taps)`` from one source to every mic, for any room.

    A flat room (no bands, no air) is exactly ``image_source_rir(room, ...)``; otherwise
    :func:`band_rirs` combined by :func:`scenesim.bands.combine_bands`.  Keywords as
    :func:`scenesim.ism.image_source_rir` (``max_order``, ``length_s``, ``highpass_hz``, ...).

    Example
    -------
    >>> from scenesim.air import AirAbsorption
    >>> room = ShoeBox((6, 5, 3), (0.1, 0.3), bands_hz=(500, 2000), air=AirAbsorption())
    >>> room_rir(room, (1, 1, 1.5), (4, 3, 1.5), fs=16000, length_s=0.2).shape
    (1, 3200)
    """
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.ShoeBox")
    if room.is_flat:
        return image_source_rir(room, source_m, mics_m, fs=fs, **kwargs)
    bands = band_rirs(room, source_m, mics_m, fs=fs, **kwargs)
    return combine_bands(bands, fs, band_centers(room))


__all__ = ["air_db_per_m", "band_centers", "band_rirs", "room_rir"]
