"""A moving source rendered image by image with time-varying delays: Doppler-correct, no block artefacts.

Every emitted sample ``x[k]`` leaves each image at emission time ``k / fs`` from the image's
position at that instant (image = ``base + sign * p(k / fs)`` per axis, ``p`` the source
path) and arrives at ``k / fs + r_k / c`` with amplitude ``g / (4 pi r_k)`` (``g`` the image's
reflection gain, times ``exp(-a r_k)`` per band with air absorption)::

    y(t) = sum_images sum_k x[k] g / (4 pi r_k) * w(t fs - k - r_k fs / c)

with ``w`` the same Hann-windowed sinc as :mod:`scenesim.room.ism`.  This is the retarded-time
solution of a moving monopole: the spacing of arrivals compresses or stretches with the
radial speed, so each image carries its own Doppler shift ``f / (1 + v_r / c)`` and the
amplitude ``1 / (4 pi r (1 + v_r / c))`` of the Lienard-Wiechert solution of the wave equation
for a moving point source (``v_r`` the speed away from the mic), with no block boundaries.  It is computed like the fast
ISM renderer: every (image, sample) is scattered with 4-point Lagrange weights onto a grid
oversampled by :data:`MOVING_OVERSAMPLING`, which is then filtered by the windowed sinc and
decimated (:func:`scenesim.room.ism.decimate_grid`, float64).  The path is sampled every
:data:`PATH_HOP_S` and linear in between (waypoint paths are linear anyway).

Which images move: those within ``c * mixing_time_s`` of a mic at the path's middle
position (the direct sound and early reflections, which carry the Doppler shifts, the
inter-mic delays and the localisation cues).  The **late** part -- the room's RIR at the
middle position minus the same early images rendered static -- is applied as one fixed
filter: its fine structure does not follow the talker (its level and decay, those of a
diffuse field, do not depend on the position), and being time-invariant it adds no
sidebands.  A source that does not move therefore gives ``x * h`` with ``h`` the static
room RIR, to rounding: early (static scatter, an LTI filter) + late (= RIR - the same early
filter).  Cost: ~n_samples x n_early_images x n_mics compiled steps -- measured 17-33 s for
2.8 s of signal in a 6 x 5 x 3 m room (80 ms mixing time, two mics) on the shared 2-core machine
at load 15, against 2-7 s for the 50 ms blocks (``benchmarks/studies/rooms_check.py``); a shorter
``mixing_time_s`` trades the late reflections' motion for speed (cost ~ mixing_time^3).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal as ss

from scenesim.room.bands import active_bands, combine_bands
from scenesim.room.ism import SINC_HALF_WIDTH, _axis_terms, decimate_grid, highpass
from scenesim.room.render import air_db_per_m, band_centers, room_rir

MOVING_OVERSAMPLING = 8
"""Oversampling U of the scatter grid (cubic-Lagrange kernel error ~0.46 / U^4 of the peak)."""
PATH_HOP_S = 0.001
"""Spacing of the path samples (s); the source moves linearly in between."""


def _band_tables(room) -> tuple[np.ndarray, np.ndarray, tuple | None]:
    """Per-band wall reflections ``(n_bands, 6)``, air nepers/m ``(n_bands,)``, band centres (None: flat)."""
    if room.is_flat:
        return np.atleast_2d(room.reflection), np.zeros(1), None
    centers = band_centers(room)
    n = len(centers)
    refl = np.array([room.band_room(b if room.bands_hz is not None else None).reflection for b in range(n)])
    air = air_db_per_m(room) * math.log(10.0) / 20.0
    return refl, air, centers


def early_images(room, centre_m, mics, radius_m: float, reflection: np.ndarray, max_order: int | None):
    """Images within ``radius_m`` of a mic for the source at ``centre_m``.

    Returns ``base (n, 3)``, ``sign (n, 3)`` (image = base + sign * source) and gains
    ``(n_bands, n)`` (per-band products of the wall reflections, as :mod:`scenesim.room.ism`).
    """
    dims = np.asarray(room.dims_m, dtype=float)
    axes = []
    for d in range(3):
        n_max = int(math.ceil(radius_m / dims[d])) + 1
        i, _, g = _axis_terms(dims[d], 0.0, np.zeros(1), n_max, reflection[:, 2 * d], reflection[:, 2 * d + 1], 1.0)
        odd = i % 2 != 0
        axes.append((i, i * dims[d] + np.where(odd, dims[d], 0.0), np.where(odd, -1.0, 1.0), g))
    (ix, bx, sx, gx), (iy, by, sy, gy), (iz, bz, sz, gz) = axes
    a, b, c = (v.ravel() for v in np.meshgrid(np.arange(ix.size), np.arange(iy.size), np.arange(iz.size), indexing="ij"))
    base = np.stack([bx[a], by[b], bz[c]], axis=1)
    sign = np.stack([sx[a], sy[b], sz[c]], axis=1)
    pos = base + sign * np.asarray(centre_m, dtype=float)
    dist = np.min(np.linalg.norm(pos[:, None, :] - mics[None, :, :], axis=-1), axis=1)
    keep = dist <= radius_m
    if max_order is not None:
        keep &= (np.abs(ix[a]) + np.abs(iy[b]) + np.abs(iz[c])) <= max_order
    gain = gx[:, a] * gy[:, b] * gz[:, c]
    keep &= np.any(gain != 0, axis=0)
    return base[keep], sign[keep], np.ascontiguousarray(gain[:, keep])


def render_early(x, room, path_ctrl, hop: int, mics, images, *, fs: int, n_out: int,
                 highpass_hz: float | None) -> np.ndarray:
    """The moving early images' contribution ``(n_mics, n_out)`` (module docstring)."""
    from scenesim.room.ism_kernels import scatter_moving  # lazy: numba import

    base, sign, gain = images
    refl, air, centers = _band_tables(room)
    n_bands = gain.shape[0]
    u = MOVING_OVERSAMPLING
    half = SINC_HALF_WIDTH
    g0 = float((half + 1) * u)
    grid = np.zeros((n_bands, mics.shape[0], (2 * (half + 1) + n_out) * u))
    q_max = g0 + float(n_out - 1 + half) * u
    scatter_moving(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(path_ctrl, dtype=float),
                   float(hop), np.ascontiguousarray(base), np.ascontiguousarray(sign), gain,
                   np.ascontiguousarray(mics, dtype=float), np.ascontiguousarray(air, dtype=float),
                   grid, u, fs * u / room.c, g0, q_max)
    if centers is None:
        y = decimate_grid(grid[0], n_out, u, dtype=np.float64)
    else:
        active = active_bands(centers, fs)
        bands = np.zeros((n_bands, mics.shape[0], n_out))
        for b in np.nonzero(active)[0]:
            bands[b] = decimate_grid(grid[b], n_out, u, dtype=np.float64)
        y = combine_bands(bands, fs, centers)
    if highpass_hz is not None:  # the causal filter room_rir applies
        y = highpass(y, highpass_hz, fs)
    return y


def render_doppler(x, room, path_ctrl, hop: int, mics, *, fs: int, length_s, max_order, mixing_time_s: float,
                   highpass_hz) -> np.ndarray:
    """Mic signals ``(n_mics, n + n_taps - 1)``: moving early images + the fixed late filter."""
    centre = path_ctrl[(path_ctrl.shape[0] - 1) // 2]
    h_full = room_rir(room, centre, mics, fs=fs, length_s=length_s, max_order=max_order, highpass_hz=highpass_hz)
    n_taps = h_full.shape[-1]
    refl, _, _ = _band_tables(room)
    images = early_images(room, centre, mics, room.c * mixing_time_s, refl, max_order)
    n_out = x.size + n_taps - 1
    # The early filter over the whole output length, so that the late filter also cancels the
    # tail of the high-pass beyond the RIR's taps: a static path then gives x * h_full exactly.
    h_early = render_early(np.ones(1), room, centre[None, :], hop, mics, images, fs=fs, n_out=n_out,
                           highpass_hz=highpass_hz)
    late = -h_early
    late[:, :n_taps] += h_full
    y = render_early(x, room, path_ctrl, hop, mics, images, fs=fs, n_out=n_out, highpass_hz=highpass_hz)
    y += ss.fftconvolve(late, x[None, :], axes=-1)[:, :n_out]
    return y

__all__ = ["MOVING_OVERSAMPLING", "PATH_HOP_S", "early_images", "render_doppler", "render_early"]
