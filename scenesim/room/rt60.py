"""Reverberation time: Sabine/Eyring formulas, their inverses, and measurement (algorithms.md section 3).

Formulas (``V`` volume m^3, ``S_w`` wall areas m^2, ``alpha_w`` energy absorption, ``c`` m/s)::

    Sabine   T = 24 ln10 V / (c sum_w S_w alpha_w)
    Eyring   T = -24 ln10 V / (c S ln(1 - alpha_mean)),  alpha_mean = sum_w S_w alpha_w / S

Measurement: Schroeder's backward integral of ``h^2`` in dB, a least-squares line fitted
between two levels (T30: -5..-35 dB, T20: -5..-25 dB, EDT: 0..-10 dB), ``RT60 = -60 / slope``.
"""

from __future__ import annotations

import math

import numpy as np

from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_fs, check_positive

_LN10_24 = 24.0 * math.log(10.0)  # 55.26...: 60 dB of energy decay expressed in nepers * 2

FIT_RANGES_DB = {"T30": (-5.0, -35.0), "T20": (-5.0, -25.0), "EDT": (0.0, -10.0)}
"""Schroeder-curve levels (start, end) in dB between which each RT60 estimator fits its line."""


def _dims(dims_m) -> np.ndarray:
    arr = np.asarray(dims_m, dtype=float) if not isinstance(dims_m, str) else None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ParameterError("dims_m", dims_m, "three finite room lengths > 0 in metres")
    return arr


def wall_areas(dims_m) -> np.ndarray:
    """Areas ``(6,)`` in m^2 of the walls in the order [x=0, x=Lx, y=0, y=Ly, z=0, z=Lz]."""
    lx, ly, lz = _dims(dims_m)
    return np.array([ly * lz, ly * lz, lx * lz, lx * lz, lx * ly, lx * ly])


def _alpha(absorption) -> np.ndarray:
    a = np.asarray(absorption, dtype=float)
    if a.ndim == 0:
        a = np.full(6, float(a))
    if a.shape != (6,) or not np.all(np.isfinite(a)) or np.any(a <= 0) or np.any(a > 1):
        raise ParameterError(
            "absorption", absorption, "a scalar or 6 per-wall energy absorptions, each in (0, 1]"
        )
    return a


def sabine_rt60(dims_m, absorption, *, c: float = 343.0) -> float:
    """Sabine reverberation time in seconds; ``absorption`` scalar or ``(6,)`` in wall order."""
    c = check_positive("c", c)
    d = _dims(dims_m)
    return float(_LN10_24 * np.prod(d) / (c * np.sum(wall_areas(d) * _alpha(absorption))))


def eyring_rt60(dims_m, absorption, *, c: float = 343.0) -> float:
    """Eyring reverberation time in seconds (area-weighted mean absorption; 0 s when it is 1)."""
    c = check_positive("c", c)
    d = _dims(dims_m)
    s = wall_areas(d)
    mean_alpha = float(np.sum(s * _alpha(absorption)) / np.sum(s))
    if mean_alpha >= 1.0:
        return 0.0
    return float(-_LN10_24 * np.prod(d) / (c * np.sum(s) * math.log1p(-mean_alpha)))


def sabine_absorption(rt60_s, dims_m, *, c: float = 343.0) -> float:
    """Uniform energy absorption giving ``rt60_s`` by Sabine; raises if it would exceed 1."""
    t = check_positive("rt60_s", rt60_s)
    c = check_positive("c", c)
    d = _dims(dims_m)
    alpha = _LN10_24 * np.prod(d) / (c * np.sum(wall_areas(d)) * t)
    if alpha > 1.0:
        t_min = _LN10_24 * np.prod(d) / (c * np.sum(wall_areas(d)))
        raise ParameterError(
            "rt60_s", t, f"an RT60 >= {t_min:.4g} s for this room (Sabine absorption would exceed 1)"
        )
    return float(alpha)


def eyring_absorption(rt60_s, dims_m, *, c: float = 343.0) -> float:
    """Uniform energy absorption giving ``rt60_s`` by Eyring: ``1 - exp(-24 ln10 V / (c S T))``."""
    t = check_positive("rt60_s", rt60_s)
    c = check_positive("c", c)
    d = _dims(dims_m)
    return float(-math.expm1(-_LN10_24 * np.prod(d) / (c * np.sum(wall_areas(d)) * t)))


def schroeder_decay_db(h) -> np.ndarray:
    """Schroeder energy decay curve in dB, normalised to 0 dB at t = 0.

    ``E(n) = 10 log10( sum_{m >= n} h[m]^2 / sum_m h[m]^2 )``.  ``h`` is ``(n_samples,)`` or
    ``(n_channels, n_samples)``; the result has the same shape.  Zero energy is floored at
    -inf-safe 1e-300 so silence gives a very low level instead of NaN.
    """
    h = np.asarray(h, dtype=float)
    if h.ndim not in (1, 2) or h.shape[-1] < 2 or not np.all(np.isfinite(h)):
        raise ParameterError("h", h, "a finite impulse response shaped (n,) or (n_ch, n) with n >= 2")
    energy = np.cumsum((h**2)[..., ::-1], axis=-1)[..., ::-1]
    total = np.maximum(energy[..., :1], 1e-300)
    return 10.0 * np.log10(np.maximum(energy, 1e-300) / total)


def measure_rt60(h, fs, *, method: str = "T30") -> float | np.ndarray:
    """Measure RT60 (s) from an impulse response by a line fit to its Schroeder curve.

    Parameters
    ----------
    h : array, shape (n_samples,) or (n_channels, n_samples)
        Impulse response(s).
    fs : int
        Sampling rate in Hz.
    method : {"T30", "T20", "EDT"}
        Fit range -5..-35 dB, -5..-25 dB or 0..-10 dB; ``RT60 = -60 / slope`` (slope in dB/s).

    Returns
    -------
    float for 1-D input, ``(n_channels,)`` array for 2-D input.

    Raises
    ------
    ParameterError
        (name ``h``) when the decay never reaches the end of the fit range, e.g. a truncated RIR.
    """
    fs = check_fs(fs)
    check_choice("method", method, tuple(FIT_RANGES_DB))
    edc = schroeder_decay_db(h)
    hi, lo = FIT_RANGES_DB[method]
    rows = np.atleast_2d(edc)
    out = np.empty(rows.shape[0])
    for ch, curve in enumerate(rows):  # few channels; the fit itself is vectorised
        # The first crossing of each level: the curve is non-increasing.
        below_lo = np.nonzero(curve <= lo)[0]
        if below_lo.size == 0 or curve[-1] > lo:
            raise ParameterError(
                "h", h, f"a decay reaching {lo:g} dB for {method} (it only reaches {curve.min():.1f} dB)"
            )
        i1 = int(below_lo[0])
        i0 = int(np.nonzero(curve <= hi)[0][0])
        if i1 - i0 < 2:
            raise ParameterError("h", h, f"a decay spanning >= 3 samples in the {method} fit range")
        t = np.arange(i0, i1 + 1) / fs
        slope = np.polyfit(t, curve[i0 : i1 + 1], 1)[0]
        if slope >= 0:
            raise ParameterError("h", h, "a decaying impulse response")
        out[ch] = -60.0 / slope
    return float(out[0]) if np.ndim(h) == 1 else out


__all__ = [
    "FIT_RANGES_DB",
    "eyring_absorption",
    "eyring_rt60",
    "measure_rt60",
    "sabine_absorption",
    "sabine_rt60",
    "schroeder_decay_db",
    "wall_areas",
]
