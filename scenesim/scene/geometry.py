"""Array geometry and the azimuth convention (algorithms.md section 1).

Convention, used everywhere in the project:

* Positions are metres in room coordinates ``(x, y, z)``; a free-field scene uses the
  same frame with the array at ``center_m``.
* The pair has a **front** mic p1 (channel 0, the *reference* mic) and a **rear**
  mic p2 (channel 1).  The array axis points from p2 to p1.
* Azimuth ``theta`` is measured in the horizontal plane from the array axis
  (endfire = 0 deg, the look direction) counter-clockwise; elevation from that plane.
  The thesis puts speech at 45 deg and the noise source at 270 deg (broadside).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_positive

SPEED_OF_SOUND_MPS = 343.0
"""Speed of sound c in m/s used unless a temperature is given."""

DEFAULT_SPACING_M = 0.0214
"""Thesis pair spacing: c/fs at 16 kHz, so d/c is one sample (the thesis' '0.0214 cm' is metres)."""


def speed_of_sound(temperature_c: float = 20.0) -> float:
    """Speed of sound in air (m/s) at ``temperature_c`` degrees Celsius: 331.3 sqrt(1 + T/273.15)."""
    t = check_finite_number("temperature_c", temperature_c)
    if t <= -273.15:
        raise ParameterError("temperature_c", t, "a temperature above absolute zero")
    return 331.3 * float(np.sqrt(1.0 + t / 273.15))


def unit_vector(azimuth_deg: float, elevation_deg: float = 0.0) -> np.ndarray:
    """Unit vector ``(3,)`` for an azimuth/elevation in degrees in the frame whose x axis is 0 deg."""
    az = np.deg2rad(check_finite_number("azimuth_deg", azimuth_deg))
    el = np.deg2rad(check_finite_number("elevation_deg", elevation_deg))
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


@dataclass(frozen=True)
class MicPair:
    """Two omnidirectional mics on an endfire axis.

    Parameters
    ----------
    center_m : tuple of 3 floats
        Midpoint of the pair in metres (room coordinates; the origin for free field).
    spacing_m : float
        Distance d between the mics in metres (default 0.0214 m).
    axis_azimuth_deg : float
        Direction of the array axis (p2 -> p1) in the room's horizontal plane, degrees
        counter-clockwise from +x.  Source azimuths are measured relative to this axis.
    """

    center_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    spacing_m: float = DEFAULT_SPACING_M
    axis_azimuth_deg: float = 0.0

    def __post_init__(self):
        center = tuple(float(check_finite_number("center_m", v)) for v in _as_3(self.center_m))
        object.__setattr__(self, "center_m", center)
        object.__setattr__(self, "spacing_m", check_positive("spacing_m", self.spacing_m))
        object.__setattr__(
            self, "axis_azimuth_deg", check_finite_number("axis_azimuth_deg", self.axis_azimuth_deg)
        )

    @property
    def axis(self) -> np.ndarray:
        """Unit vector ``(3,)`` from the rear mic to the front mic."""
        return unit_vector(self.axis_azimuth_deg)

    @property
    def positions_m(self) -> np.ndarray:
        """Mic positions ``(2, 3)`` in metres: row 0 front p1 (reference), row 1 rear p2."""
        c = np.asarray(self.center_m)
        half = 0.5 * self.spacing_m * self.axis
        return np.stack([c + half, c - half])

    def delay_s(self, c: float = SPEED_OF_SOUND_MPS) -> float:
        """Inter-mic travel time d/c in seconds (the differential beamformer's delay T)."""
        return self.spacing_m / c

    def direction(self, azimuth_deg: float, elevation_deg: float = 0.0) -> np.ndarray:
        """Unit vector ``(3,)`` in room coordinates towards a source at an array-relative azimuth."""
        return unit_vector(self.axis_azimuth_deg + azimuth_deg, elevation_deg)

    def source_position(
        self, azimuth_deg: float, distance_m: float, elevation_deg: float = 0.0
    ) -> np.ndarray:
        """Position ``(3,)`` in metres of a source at ``distance_m`` from the pair's centre."""
        r = check_positive("distance_m", distance_m)
        return np.asarray(self.center_m) + r * self.direction(azimuth_deg, elevation_deg)

    def azimuth_of(self, point_m) -> float:
        """Array-relative azimuth in degrees [0, 360) of a point (its projection on the horizontal plane)."""
        v = np.asarray(_as_3(point_m), dtype=float) - np.asarray(self.center_m)
        if np.hypot(v[0], v[1]) == 0.0:
            raise ParameterError("point_m", point_m, "a point off the vertical line through the pair")
        return float((np.rad2deg(np.arctan2(v[1], v[0])) - self.axis_azimuth_deg) % 360.0)


def _as_3(value) -> tuple:
    try:
        items = tuple(value)
    except TypeError:
        raise ParameterError("position", value, "a sequence of 3 coordinates in metres") from None
    if len(items) != 3:
        raise ParameterError("position", value, "a sequence of 3 coordinates in metres")
    return items
