"""Frequency-dependent source directivity for the image-source method.

A :class:`Directivity` is axisymmetric about an axis given by azimuth (degrees from +x in the
horizontal plane, towards +y) and elevation (degrees above the horizontal plane).  Per octave
band ``b`` its pressure gain is a polynomial in ``cos(theta)`` (theta: angle between the
emission direction and the axis)::

    D_b(theta) = sum_k coefficients[b, k] cos(theta)^k

which covers the cardioid family ``(p + (1 - p) cos theta)^n`` (pyroomacoustics'
``CardioidFamily`` is n = 1) and any pattern fitted by a polynomial, and keeps the compiled
ISM kernel generic.  The ISM evaluates it at each image's emission direction (the direction
from the image to the mic, mirrored back into the source's frame by the image's reflection
parity), renders one RIR per band and merges them (:mod:`scenesim.room.ism_bands`).

:meth:`Directivity.talker` is a first-order cardioid family per octave whose front-to-back
ratio rises with frequency -- 0.5, 1, 2, 4, 7, 10, 13 dB at 125 Hz ... 8 kHz.  These are round
numbers of the size reported for speech (Chu & Warnock 2002, NRC report IRC-RR-104; Monson et
al. 2012: nearly omnidirectional below 500 Hz, 10-15 dB front/back above 4 kHz), NOT a fit to
one published data set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scenesim.errors import ParameterError
from scenesim.room.ism_bands import OCTAVE_CENTRES_HZ, check_bands
from scenesim.validate import check_finite_number

TALKER_FRONT_BACK_DB = (0.5, 1.0, 2.0, 4.0, 7.0, 10.0, 13.0)
"""Front-to-back pressure ratio (dB) of :meth:`Directivity.talker` per octave 125 Hz..8 kHz."""


def _cardioid_poly(p: float, order: int) -> np.ndarray:
    """Coefficients in cos(theta) of ``(p + (1 - p) cos theta)^order``, lowest power first."""
    return np.array([math.comb(order, k) * p ** (order - k) * (1 - p) ** k for k in range(order + 1)])


@dataclass(frozen=True)
class Directivity:
    """Axisymmetric per-band source directivity (see module docstring).

    Parameters
    ----------
    coefficients : (n_bands, K) array-like
        Polynomial coefficients in cos(theta), lowest power first, one row per band.
    bands_hz : (n_bands,) array-like
        Band centre frequencies in Hz (one band: frequency independent, any centre).
    azimuth_deg, elevation_deg : float
        Axis direction.

    Example
    -------
    >>> d = Directivity.cardioid_family(0.5, azimuth_deg=90.0)
    >>> [round(float(v), 6) for v in d.gains(np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]))[:, 0]]
    [1.0, 0.0]
    """

    coefficients: tuple
    bands_hz: tuple = (1000.0,)
    azimuth_deg: float = 0.0
    elevation_deg: float = 0.0

    def __post_init__(self):
        bands = check_bands(self.bands_hz)
        coef = np.atleast_2d(np.asarray(self.coefficients, dtype=float))
        if coef.ndim != 2 or coef.shape[0] != bands.size or coef.shape[1] == 0 \
                or not np.all(np.isfinite(coef)):
            raise ParameterError(
                "coefficients", self.coefficients, f"finite array shaped ({bands.size}, K >= 1)"
            )
        object.__setattr__(self, "coefficients", tuple(map(tuple, coef.tolist())))
        object.__setattr__(self, "bands_hz", tuple(bands.tolist()))
        object.__setattr__(self, "azimuth_deg", check_finite_number("azimuth_deg", self.azimuth_deg))
        el = check_finite_number("elevation_deg", self.elevation_deg)
        if abs(el) > 90:
            raise ParameterError("elevation_deg", el, "an elevation in [-90, 90] degrees")
        object.__setattr__(self, "elevation_deg", el)

    # ----------------------------------------------------------------- constructors
    @classmethod
    def cardioid_family(cls, p, *, order=1, bands_hz=None, azimuth_deg=0.0, elevation_deg=0.0):
        """``(p + (1 - p) cos theta)^order``; ``p`` (and ``order``) scalar or one per band.

        p = 1 omni, 0.5 cardioid, 0.25 hypercardioid, 0 figure-eight (pyroomacoustics'
        ``CardioidFamily(p=...)`` convention for order 1).
        """
        p_arr = np.atleast_1d(np.asarray(p, dtype=float))
        o_arr = np.atleast_1d(np.asarray(order))
        n = max(p_arr.size, o_arr.size)
        if bands_hz is None:
            bands_hz = (1000.0,) if n == 1 else OCTAVE_CENTRES_HZ[:n]
        n = max(n, len(bands_hz))
        if not np.all(np.isfinite(p_arr)) or np.any((p_arr < 0) | (p_arr > 1)) \
                or p_arr.size not in (1, n):
            raise ParameterError("p", p, "values in [0, 1]" + _count_text(n))
        if not np.all(o_arr == np.round(o_arr)) or np.any(o_arr < 0) or o_arr.size not in (1, n):
            raise ParameterError("order", order, "integers >= 0" + _count_text(n))
        p_arr, o_arr = np.broadcast_to(p_arr, n), np.broadcast_to(o_arr.astype(int), n)
        width = int(o_arr.max()) + 1
        coef = np.zeros((n, width))
        for b in range(n):
            poly = _cardioid_poly(float(p_arr[b]), int(o_arr[b]))
            coef[b, : poly.size] = poly
        return cls(coef, tuple(bands_hz), azimuth_deg, elevation_deg)

    @classmethod
    def talker(cls, *, azimuth_deg=0.0, elevation_deg=0.0):
        """A talker: first-order cardioid family per octave, front/back :data:`TALKER_FRONT_BACK_DB`.

        Back gain ``2p - 1 = 10^(-FB/20)`` gives ``p = (1 + 10^(-FB/20)) / 2``.
        """
        p = [(1.0 + 10 ** (-fb / 20.0)) / 2.0 for fb in TALKER_FRONT_BACK_DB]
        return cls.cardioid_family(
            p, bands_hz=OCTAVE_CENTRES_HZ, azimuth_deg=azimuth_deg, elevation_deg=elevation_deg
        )

    # ----------------------------------------------------------------- evaluation
    @property
    def axis(self) -> np.ndarray:
        """Unit vector (3,) of the axis."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])

    @property
    def coefficient_array(self) -> np.ndarray:
        """(n_bands, K) float array of the coefficients."""
        return np.asarray(self.coefficients, dtype=float)

    @property
    def n_bands(self) -> int:
        return len(self.bands_hz)

    def gains(self, directions) -> np.ndarray:
        """Pressure gains ``(n, n_bands)`` for directions ``(n, 3)`` (normalised here)."""
        u = np.atleast_2d(np.asarray(directions, dtype=float))
        cos_t = (u @ self.axis) / np.linalg.norm(u, axis=1)
        return np.polynomial.polynomial.polyval(cos_t, self.coefficient_array.T).T


def _count_text(n: int) -> str:
    """How many values a per-band coefficient takes: one, or one per band.

    >>> _count_text(1), _count_text(7)
    ('', ': one value, or 7 (one per band)')
    """
    return "" if n == 1 else f": one value, or {n} (one per band)"
