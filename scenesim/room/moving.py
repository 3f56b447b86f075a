"""A source moving along a path (issue 10, 18).

Two renderers:

* ``method="doppler"`` (default): every early image follows the path sample by sample with
  its own time-varying delay (fractional-delay interpolation per sample, so each image has
  its Doppler shift), the late reverberation a fixed filter -- no block artefacts
  (:mod:`scenesim.room.moving_doppler`, whose docstring gives the method and its limits).
  Sidebands of a moving 1-4 kHz tone outside its Doppler band: <= -60 dB
  (``tests/test_moving.py``; the block method below puts them at -20..-26 dB).
* ``method="blocks"``: per-block RIRs cross-faded on the emitted signal, described below.

The signal is cut into overlapping blocks centred on ``t_k = k * block_s``; block ``k`` is
weighted by a raised-cosine window ``w_k(t) = cos^2(pi/2 (t - t_k) / block_s)`` for
``|t - t_k| < block_s`` (the first and last windows stay at 1 before ``t_0`` / after the last
centre), so ``sum_k w_k(t) = 1`` at every sample.  Each block is convolved with the RIR of the
source position at ``t_k`` and the results are added::

    y = sum_k  h(p(t_k)) * (w_k x)

Sound emitted at time t therefore leaves from (a blend of the two nearest block positions
to) ``p(t)``.  There is no time-varying delay inside a block, so there is no Doppler shift
(about 0.3 % at 1 m/s, inaudible for speech); the smooth windows make the change between
positions click-free.  A path that does not move reproduces the static rendering exactly
(the windows sum to 1 and every block uses the same RIR).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy import signal as ss

from scenesim.errors import ParameterError
from scenesim.room.ism import DEFAULT_MIXING_TIME_S, default_length_s
from scenesim.room.render import DEFAULT_HIGHPASS_HZ, room_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.validate import check_choice, check_fs, check_positive


def path_positions(path_m, times_s: np.ndarray, *, duration_s: float, waypoint_times_s=None) -> np.ndarray:
    """Positions ``(len(times_s), 3)`` of a path at ``times_s``.

    ``path_m`` is a callable ``t_s -> (3,)`` or waypoints ``(n, 3)``, linearly interpolated at
    ``waypoint_times_s`` (default: spread evenly over ``[0, duration_s]``; held beyond the ends).
    """
    times = np.asarray(times_s, dtype=float)
    if callable(path_m):
        pos = np.array([np.asarray(path_m(float(t)), dtype=float) for t in times])
        if pos.shape != (times.size, 3) or not np.all(np.isfinite(pos)):
            raise ParameterError("path_m", path_m, "a function of time (s) returning 3 finite coordinates")
        return pos
    way = np.asarray(path_m, dtype=float) if not isinstance(path_m, str) else None
    if way is None or way.ndim != 2 or way.shape[1] != 3 or way.shape[0] < 1 or not np.all(np.isfinite(way)):
        raise ParameterError("path_m", path_m, "waypoints shaped (n, 3) in metres, or a function of time")
    if waypoint_times_s is None:
        wt = np.linspace(0.0, duration_s, way.shape[0]) if way.shape[0] > 1 else np.zeros(1)
    else:
        wt = np.asarray(waypoint_times_s, dtype=float)
        if wt.shape != (way.shape[0],) or not np.all(np.isfinite(wt)) or np.any(np.diff(wt) <= 0):
            raise ParameterError("waypoint_times_s", waypoint_times_s,
                                 f"{way.shape[0]} strictly increasing times in seconds")
    return np.stack([np.interp(times, wt, way[:, d]) for d in range(3)], axis=1)


def crossfade_windows(n_samples: int, fs: int, block_s: float) -> tuple[np.ndarray, list[tuple[int, np.ndarray]]]:
    """Block centres (s) and, per block, ``(start sample, window)``; the windows sum to 1."""
    hop = max(1, int(round(block_s * fs)))
    n_blocks = max(1, math.ceil((n_samples - 1) / hop) + 1) if n_samples > 1 else 1
    centres = np.arange(n_blocks) * hop
    n = np.arange(n_samples)
    out = []
    for k, c in enumerate(centres):
        lo, hi = max(0, c - hop + 1), min(n_samples, c + hop)
        if k == 0:
            lo = 0
        if k == n_blocks - 1:
            hi = n_samples
        u = (n[lo:hi] - c) / hop
        w = np.cos(0.5 * np.pi * np.clip(u, -1.0, 1.0)) ** 2
        if k == 0:
            w[u < 0] = 1.0
        if k == n_blocks - 1:
            w[u > 0] = 1.0
        out.append((lo, w))
    return centres / fs, out


def render_moving_source(signal, room: ShoeBox, path_m: Callable | np.ndarray, mics_m, *, fs: int,
                         block_s: float = 0.05, waypoint_times_s=None, length_s: float | None = None,
                         max_order: int | None = None,
                         highpass_hz: float | None = DEFAULT_HIGHPASS_HZ, method: str = "doppler",
                         mixing_time_s: float = DEFAULT_MIXING_TIME_S) -> np.ndarray:
    """Mic signals ``(n_mics, n_samples + n_taps - 1)`` of a source moving along ``path_m``.

    Parameters
    ----------
    signal : (n_samples,) array
        The emitted (dry) signal.
    room : ShoeBox
        Any room (flat, octave bands, air): RIRs by :func:`scenesim.room.render.room_rir`.
    path_m : callable or (n, 3) array
        Source position in metres as a function of time (s), or waypoints (see
        :func:`path_positions`).
    mics_m : (3,) or (n_mics, 3) array
        Mic positions in metres (static).
    fs : int
        Sampling rate in Hz.
    block_s : float
        ``method="blocks"`` only: spacing of the RIR updates in seconds (cross-fade length).
    waypoint_times_s : (n,) array, optional
        Times of the waypoints; default evenly over the signal.
    length_s, max_order : optional
        RIR length / image order (default length: :func:`scenesim.room.ism.default_length_s` at the
        path position farthest from the mics).
    highpass_hz : float or None
        RIR high-pass as :func:`scenesim.room.render.room_rir` (default 20 Hz; None: raw).
    method : {"doppler", "blocks"}
        Per-image time-varying delays (default) or cross-faded block RIRs (module docstring).
    mixing_time_s : float
        ``method="doppler"``: images arriving within this time move with the source; the rest
        is a fixed late filter (default :data:`scenesim.room.ism.DEFAULT_MIXING_TIME_S`).

    Examples
    --------
    >>> room = ShoeBox((5, 4, 3), 0.4)
    >>> x = np.random.default_rng(0).standard_normal(8000)
    >>> y = render_moving_source(x, room, [(1, 1, 1.5), (1, 3, 1.5)], [(4, 2, 1.5)], fs=16000,
    ...                          length_s=0.1)
    >>> y.shape
    (1, 9599)
    """
    fs = check_fs(fs)
    block_s = check_positive("block_s", block_s)
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1 or x.size < 1 or not np.all(np.isfinite(x)):
        raise ParameterError("signal", getattr(x, "shape", signal), "a finite 1-D signal (n_samples,)")
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
    check_choice("method", method, ("doppler", "blocks"))
    mics = np.atleast_2d(np.asarray(mics_m, dtype=float))
    if method == "doppler":
        return _doppler(x, room, path_m, mics, fs=fs, waypoint_times_s=waypoint_times_s, length_s=length_s,
                        max_order=max_order, highpass_hz=highpass_hz,
                        mixing_time_s=check_positive("mixing_time_s", mixing_time_s))
    centres_s, windows = crossfade_windows(x.size, fs, block_s)
    pos = path_positions(path_m, centres_s, duration_s=(x.size - 1) / fs, waypoint_times_s=waypoint_times_s)
    for k, p in enumerate(pos):
        room.check_inside(p, name=f"path_m at t={centres_s[k]:.3f} s")
    length_s = _default_length(room, pos, mics, length_s, max_order)
    rir_cache: dict[tuple, np.ndarray] = {}
    pieces = []
    for (start, w), p in zip(windows, pos):
        key = tuple(np.round(p, 12))
        if key not in rir_cache:  # a path that pauses reuses its RIR
            rir_cache[key] = room_rir(room, p, mics, fs=fs, length_s=length_s, max_order=max_order,
                                      highpass_hz=highpass_hz)
        pieces.append((start, w, rir_cache[key]))
    n_taps = max(h.shape[-1] for _, _, h in pieces)
    y = np.zeros((mics.shape[0], x.size + n_taps - 1))
    for start, w, h in pieces:
        seg = ss.fftconvolve(h, (w * x[start : start + w.size])[None, :], axes=-1)
        y[:, start : start + seg.shape[-1]] += seg
    return y


def _default_length(room, pos, mics, length_s, max_order):
    """Default RIR length: :func:`scenesim.room.ism.default_length_s` at the path position farthest from the mics."""
    if length_s is None and max_order is None:
        far = pos[int(np.argmax([np.max(np.linalg.norm(mics - p, axis=1)) for p in pos]))]
        length_s = default_length_s(room, far, mics)
    return length_s


def _doppler(x, room, path_m, mics, *, fs, waypoint_times_s, length_s, max_order, highpass_hz, mixing_time_s):
    from scenesim.room.moving_doppler import PATH_HOP_S, render_doppler

    hop = max(1, int(round(PATH_HOP_S * fs)))
    n_ctrl = max(1, math.ceil((x.size - 1) / hop) + 1)
    times = np.arange(n_ctrl) * hop / fs
    pos = path_positions(path_m, times, duration_s=(x.size - 1) / fs, waypoint_times_s=waypoint_times_s)
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    for p in (lo, hi):  # the box is convex: its corners of the path bound every sample
        room.check_inside(p, name="path_m")
    length_s = _default_length(room, pos, mics, length_s, max_order)
    return render_doppler(x, room, pos, hop, mics, fs=fs, length_s=length_s, max_order=max_order,
                          mixing_time_s=mixing_time_s, highpass_hz=highpass_hz)


__all__ = ["crossfade_windows", "path_positions", "render_moving_source"]
