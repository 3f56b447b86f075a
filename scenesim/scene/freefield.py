"""Free-field propagation to a mic pair: plane waves (far field) and point sources (near field).

algorithms.md section 2.  Delays are applied with the windowed-sinc fractional delay of
:mod:`scenesim.scene.fractional_delay` (integer part by shifting, fractional part by the filter).

Plane wave: mic i receives ``s(t - tau_i)`` with ``tau_i = -(r_i . u) / c``, ``r_i`` the mic
position relative to the pair centre and ``u`` the unit vector towards the source, so for a
source at 0 deg the front mic (channel 0) leads.  Since ``tau_i`` can be negative, a common
**bulk delay** ``max_i |r_i| / c`` (= d / (2c), half a sample for the thesis pair at 16 kHz)
is added to every channel, whatever the direction: the applied delays are
``|r_i| / c + tau_i`` in ``[0, d/c]``.  :func:`plane_wave_delays` returns them, so a clean
reference with the same timing as channel 0 can be built (``plane_wave(...)[0]`` is that
reference).

Point source: mic i receives ``s(t - R_i / c) / (4 pi R_i)``, ``R_i = |x_s - x_i|``, with
t = 0 at emission (no bulk delay), the same time origin as the image-source RIRs.

Outputs have the input's length: the delayed tail beyond it is cut.
"""

from __future__ import annotations

import numpy as np

from scenesim.errors import ParameterError
from scenesim.scene.fractional_delay import DEFAULT_N_TAPS, delay_signal
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS, MicPair
from scenesim.validate import check_finite_number, check_fs, check_positive, check_signal


def _mono(signal, name: str = "signal") -> np.ndarray:
    arr = np.asarray(signal)
    if arr.ndim == 2 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 1:
        raise ParameterError(name, arr, "a mono signal shaped (n_samples,) or (1, n_samples)")
    return check_signal(arr[None, :], name=name)[0]


def _check_pair(pair) -> MicPair:
    if not isinstance(pair, MicPair):
        raise ParameterError("pair", pair, "a scenesim.scene.geometry.MicPair")
    return pair


def plane_wave_delays(
    pair: MicPair,
    *,
    azimuth_deg: float,
    elevation_deg: float = 0.0,
    fs: int,
    c: float = SPEED_OF_SOUND_MPS,
) -> np.ndarray:
    """Per-mic delays ``(2,)`` in samples applied by :func:`plane_wave`, bulk delay included.

    ``delay_i = fs (max_j |r_j| - r_i . u) / c``; the bulk ``fs max_j |r_j| / c`` does not
    depend on the direction, so relative timings across directions are preserved.
    """
    pair = _check_pair(pair)
    fs = check_fs(fs)
    c = check_positive("c", c)
    u = pair.direction(azimuth_deg, elevation_deg)
    r = pair.positions_m - np.asarray(pair.center_m)
    bulk = float(np.max(np.linalg.norm(r, axis=1)))
    return fs * (bulk - r @ u) / c


def plane_wave(
    signal,
    pair: MicPair,
    *,
    azimuth_deg: float,
    elevation_deg: float = 0.0,
    fs: int,
    c: float = SPEED_OF_SOUND_MPS,
    n_taps: int = DEFAULT_N_TAPS,
) -> np.ndarray:
    """Far-field image ``(2, n)`` of a mono ``signal`` arriving from a direction.

    Parameters
    ----------
    signal : array (n,)
        Source signal as it would be received at the pair centre (unit amplitude).
    pair : MicPair
        The array; row/channel 0 is the front (reference) mic.
    azimuth_deg, elevation_deg : float
        Array-relative direction of the source (endfire = 0 deg, counter-clockwise).
    fs : int
        Sampling rate in Hz.
    c : float
        Speed of sound in m/s.
    n_taps : int
        Fractional-delay filter length.

    Returns
    -------
    ndarray (2, n)
        ``x_i[n] = s(n - delay_i)`` with the delays of :func:`plane_wave_delays`.
    """
    s = _mono(signal)
    check_finite_number("azimuth_deg", azimuth_deg)
    check_finite_number("elevation_deg", elevation_deg)
    d = plane_wave_delays(pair, azimuth_deg=azimuth_deg, elevation_deg=elevation_deg, fs=fs, c=c)
    return delay_signal(np.broadcast_to(s, (2, s.size)), d, n_taps=n_taps)


def point_source_geometry(
    pair: MicPair, *, position_m, fs: int, c: float = SPEED_OF_SOUND_MPS
) -> tuple[np.ndarray, np.ndarray]:
    """Delays ``(2,)`` in samples (``fs R_i / c``) and gains ``(2,)`` (``1 / (4 pi R_i)``)."""
    pair = _check_pair(pair)
    fs = check_fs(fs)
    c = check_positive("c", c)
    pos = np.asarray(position_m, dtype=float)
    if pos.shape != (3,) or not np.all(np.isfinite(pos)):
        raise ParameterError("position_m", position_m, "3 finite coordinates in metres")
    dist = np.linalg.norm(pair.positions_m - pos[None, :], axis=1)
    if np.any(dist < 1e-3):
        raise ParameterError("position_m", position_m, "a point at least 1 mm from every mic")
    return fs * dist / c, 1.0 / (4.0 * np.pi * dist)


def point_source(
    signal,
    pair: MicPair,
    *,
    position_m,
    fs: int,
    c: float = SPEED_OF_SOUND_MPS,
    n_taps: int = DEFAULT_N_TAPS,
) -> np.ndarray:
    """Near-field image ``(2, n)``: ``x_i[n] = s(n - fs R_i / c) / (4 pi R_i)``.

    ``signal`` (n,) is the source's emitted signal (volume velocity scaled so that the free
    field Green's function is ``1 / (4 pi R)``); t = 0 at emission.
    """
    s = _mono(signal)
    delays, gains = point_source_geometry(pair, position_m=position_m, fs=fs, c=c)
    return gains[:, None] * delay_signal(np.broadcast_to(s, (2, s.size)), delays, n_taps=n_taps)
