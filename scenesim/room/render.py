"""RIRs of any :class:`~scenesim.room.shoebox.ShoeBox`: flat rooms by one image-source render, rooms with
octave-band absorption and/or air absorption band by band (issue 10).

For a room with ``bands_hz`` band ``b`` is rendered by :func:`scenesim.room.ism.image_source_rir`
with that band's wall reflection coefficients (:meth:`ShoeBox.band_room`); with ``air`` each
band's RIR is multiplied by ``10^(-a_b c t / 20)`` (:func:`scenesim.room.air.air_gain`, ``a_b`` at the
band's exact ISO midband frequency); the band RIRs are then combined through the
complementary zero-phase filter bank of :mod:`scenesim.room.bands`::

    h = sum_b  W_b * ( g_b(t) . h_b(t) )        (W_b sum to 1: identical h_b give h_b back)

A flat room with air is rendered once and split into the default octaves.  Bands above
Nyquist (zero weight) are skipped.

High-pass: :func:`room_rir` (and so :func:`scenesim.room.cache.cached_rir` and every rendered
scene) applies a causal 2nd-order Butterworth high-pass at :data:`DEFAULT_HIGHPASS_HZ` = 20 Hz
by default; :func:`scenesim.room.ism.image_source_rir` stays the raw image sum (no default filter:
it is the primitive checked against the slow reference and pyroomacoustics).  Why: the raw
ISM RIR has a DC/infrasonic build-up (mean/peak 1.6-12 %, DC gain 38-56 dB above the median
magnitude in calibrated rooms of RT60 0.6-1.5 s); convolved with the artificial voice it puts
-16..-23 dB of the reverberant speech image's energy below 50 Hz, which energy-based SNRs then
count as speech.  The 20 Hz high-pass brings that to -31..-40 dB and changes the 90 Hz-8 kHz
level by < 0.001 dB (measured; pyroomacoustics likewise high-passes at 10 Hz by default).
Pass ``highpass_hz=None`` for the raw sum.
"""

from __future__ import annotations

import numpy as np

from scenesim.errors import ParameterError
from scenesim.room.air import air_gain
from scenesim.room.bands import OCTAVE_CENTERS_HZ, active_bands, combine_bands, exact_midband_hz
from scenesim.room.ism import default_length_s, highpass, image_source_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.validate import check_fs, check_range

DEFAULT_HIGHPASS_HZ = 20.0
"""Default high-pass cut-off (Hz) of :func:`room_rir` (module docstring says why)."""


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

    Bands above Nyquist are zeros.  ``kwargs`` go to :func:`scenesim.room.ism.image_source_rir`.
    """
    fs = check_fs(fs)
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
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


def room_rir(room: ShoeBox, source_m, mics_m, *, fs: int, highpass_hz: float | None = DEFAULT_HIGHPASS_HZ,
             **kwargs) -> np.ndarray:
    """RIRs ``(n_mics, n_taps)`` from one source to every mic, for any room.

    A flat room (no bands, no air) is exactly ``image_source_rir(room, ..., highpass_hz=highpass_hz)``;
    otherwise :func:`band_rirs` combined by :func:`scenesim.room.bands.combine_bands`, then the same
    high-pass.  ``highpass_hz`` defaults to :data:`DEFAULT_HIGHPASS_HZ` (None: raw image sum).
    Other keywords as :func:`scenesim.room.ism.image_source_rir` (``max_order``, ``length_s``, ...).

    Examples
    --------
    >>> from scenesim.room.air import AirAbsorption
    >>> room = ShoeBox((6, 5, 3), (0.1, 0.3), bands_hz=(500, 2000), air=AirAbsorption())
    >>> room_rir(room, (1, 1, 1.5), (4, 3, 1.5), fs=16000, length_s=0.2).shape
    (1, 3200)
    """
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
    if room.is_flat:
        return image_source_rir(room, source_m, mics_m, fs=fs, highpass_hz=highpass_hz, **kwargs)
    fs = check_fs(fs)
    if highpass_hz is not None:
        highpass_hz = check_range("highpass_hz", highpass_hz, 0.0, fs / 2, lo_open=True, hi_open=True)
    bands = band_rirs(room, source_m, mics_m, fs=fs, **kwargs)
    h = combine_bands(bands, fs, band_centers(room))
    if highpass_hz is not None:  # the same causal filter image_source_rir applies
        h = highpass(h, highpass_hz, fs)
    return h


__all__ = ["DEFAULT_HIGHPASS_HZ", "air_db_per_m", "band_centers", "band_rirs", "room_rir"]
