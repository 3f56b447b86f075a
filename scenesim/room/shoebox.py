"""Shoebox room description: dimensions, per-wall (optionally per-octave) absorption, air (algorithms.md sections 1, 3).

The room is ``[0, Lx] x [0, Ly] x [0, Lz]`` metres.  Walls are ordered
``[x=0, x=Lx, y=0, y=Ly, z=0, z=Lz]`` (pyroomacoustics' order).  ``absorption`` is the
*energy* absorption coefficient alpha; the pressure reflection coefficient is
``b = sqrt(1 - alpha)``.

Absorption is frequency-independent (a scalar or 6 per-wall values) or given per octave
band: a ``(6, n_bands)`` table with ``bands_hz`` naming the band centres.  ``air`` (an
:class:`scenesim.room.air.AirAbsorption`) adds ISO 9613-1 air absorption.  Rooms with bands or air
are rendered by :func:`scenesim.room.render.room_rir` (one image-source RIR per band through the
complementary filter bank of :mod:`scenesim.room.bands`); :meth:`ShoeBox.band_room` gives the
flat room of one band.

A room is given either by its absorption or by a target ``rt60_s`` and a method:

* ``"sabine"``: uniform alpha from Sabine's formula (pyroomacoustics' ``inverse_sabine``).
* ``"eyring"``: uniform alpha from Eyring's formula.
* ``"calibrated"``: closed loop on rendered RIRs -- a thin compatibility path to
  :func:`scenesim.room.calibration.calibrate_room` (which is the API to use: it returns a room and
  also calibrates per octave band and scales per-wall profiles).  With ``rt60_method=
  "calibrated"`` an ``absorption`` profile may be given too: it is scaled to reach ``rt60_s``.

This module does not import the renderer (no room <-> ISM import cycle): the calibration
function is registered here by :mod:`scenesim.room.calibration` when the package is imported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from scenesim.errors import ParameterError, ScenesimError
from scenesim.room.rt60 import (
    eyring_absorption,
    eyring_rt60,
    sabine_absorption,
    sabine_rt60,
    wall_areas,
)
from scenesim.validate import check_choice, check_positive

RT60_METHODS = ("sabine", "eyring", "calibrated")

_calibrator: Callable | None = None


def register_calibrator(fn: Callable) -> None:
    """Install ``fn(dims_m, rt60_s, *, absorption, c) -> alpha (6,)`` for ``rt60_method="calibrated"``.

    Called by :mod:`scenesim.room.calibration` on import (dependency inversion: the value object
    does not import the renderer).
    """
    global _calibrator
    _calibrator = fn


def _check_absorption(value, bands: tuple | None) -> tuple[object, np.ndarray]:
    """Validated ``(stored, alpha)``: alpha ``(6,)`` (flat) or ``(6, n_bands)`` (banded)."""
    a = np.asarray(value, dtype=float) if not isinstance(value, str) else None
    shapes = ((), (6,)) if bands is None else ((), (6,), (len(bands),), (6, len(bands)))
    if a is None or a.shape not in shapes:
        allowed = "a scalar or 6 per-wall values, each in (0, 1]" if bands is None else (
            f"a scalar, 6 per-wall values, {len(bands)} per-band values or a (6, {len(bands)}) table"
        )
        raise ParameterError("absorption", value, allowed)
    if not np.all(np.isfinite(a)) or np.any(a <= 0) or np.any(a > 1):
        raise ParameterError("absorption", value, "values in (0, 1]")
    if bands is None:
        stored = float(a) if a.ndim == 0 else tuple(float(v) for v in a)
        return stored, np.broadcast_to(a, (6,)).copy()
    if a.ndim == 1 and a.shape == (len(bands),) and len(bands) != 6:
        a = np.broadcast_to(a[None, :], (6, len(bands)))  # one value per band for every wall
    elif a.ndim == 1:  # (6,) per wall, the same in every band
        a = np.broadcast_to(a[:, None], (6, len(bands)))
    full = np.broadcast_to(a, (6, len(bands))).copy()
    return tuple(tuple(float(v) for v in row) for row in full), full


@dataclass(frozen=True)
class ShoeBox:
    """A rectangular room with per-wall (optionally per-octave) energy absorption.

    Parameters
    ----------
    dims_m : 3 floats
        Room lengths (Lx, Ly, Lz) in metres, each > 0.
    absorption : float, 6 floats or (6, n_bands) table, optional
        Energy absorption in (0, 1]: one value for all walls, one per wall in the order
        [x=0, x=Lx, y=0, y=Ly, z=0, z=Lz], or (with ``bands_hz``) one per wall and band
        (``n_bands`` values are taken as the same for every wall; when ``n_bands == 6`` a
        1-D value is per wall).  Exactly one of ``absorption`` and ``rt60_s``, except with
        ``rt60_method="calibrated"`` where a given absorption is the profile to scale.
    rt60_s : float, optional
        Target reverberation time in seconds (uniform absorption derived from it).
    rt60_method : {"sabine", "eyring", "calibrated"}
        How ``rt60_s`` becomes an absorption (see the module docstring).
    bands_hz : floats, optional
        Octave-band centres (Hz) of a per-band absorption table, e.g.
        :data:`scenesim.room.bands.OCTAVE_CENTERS_HZ`.
    air : scenesim.room.air.AirAbsorption, optional
        ISO 9613-1 air absorption (temperature, humidity).
    scattering : float, 6 floats or (6, n_bands) table, optional
        Scattering coefficient in [0, 1) per wall (and band): the share of the reflected
        energy leaving diffusely (:mod:`scenesim.room.scattering`; 6 values are per wall, another
        count ``n_bands`` per band).  None or 0: purely specular (the class
        default); :func:`scenesim.room.calibration.calibrate_room` uses
        :data:`scenesim.room.scattering.DEFAULT_SCATTERING` = 0.5, typical of furnished rooms.
    target_rt60_s : float or n_bands floats, optional
        The reverberation time an absorption was calibrated for (recorded by
        :func:`scenesim.room.calibration.calibrate_room`; informational, sets default RIR lengths).
    c : float
        Speed of sound in m/s.
    min_wall_distance_m : float
        Sources and mics must stay at least this far from every wall (:meth:`check_inside`).

    Raises
    ------
    ParameterError
        Non-positive dims, absorption outside (0, 1], both or neither of absorption/rt60_s,
        or an RT60 the room cannot have (Sabine absorption > 1).

    Examples
    --------
    >>> ShoeBox((6, 5, 3), (0.1, 0.2), bands_hz=(500, 1000)).wall_absorption.shape
    (6, 2)
    """

    dims_m: tuple[float, float, float]
    absorption: float | tuple | None = None
    _: KW_ONLY
    rt60_s: float | None = None
    rt60_method: str = "sabine"
    c: float = 343.0
    min_wall_distance_m: float = 0.1
    bands_hz: tuple[float, ...] | None = None
    air: object | None = None
    target_rt60_s: float | tuple[float, ...] | None = None
    scattering: float | tuple | None = None
    _alpha: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        dims = np.asarray(self.dims_m, dtype=float) if not isinstance(self.dims_m, str) else None
        if dims is None or dims.shape != (3,) or not np.all(np.isfinite(dims)) or np.any(dims <= 0):
            raise ParameterError("dims_m", self.dims_m, "three finite room lengths > 0 in metres")
        object.__setattr__(self, "dims_m", tuple(float(v) for v in dims))
        object.__setattr__(self, "c", check_positive("c", self.c))
        object.__setattr__(
            self,
            "min_wall_distance_m",
            check_positive("min_wall_distance_m", self.min_wall_distance_m, allow_zero=True),
        )
        check_choice("rt60_method", self.rt60_method, RT60_METHODS)
        self._check_extras()
        profile_calibration = self.absorption is not None and self.rt60_s is not None \
            and self.rt60_method == "calibrated"
        if (self.absorption is None) == (self.rt60_s is None) and not profile_calibration:
            raise ParameterError(
                "absorption", self.absorption,
                "exactly one of absorption and rt60_s to be given (or both with "
                "rt60_method='calibrated', which scales the absorption profile to rt60_s)",
            )
        if self.bands_hz is not None and self.rt60_s is not None and not profile_calibration:
            raise ParameterError("bands_hz", self.bands_hz, "a per-band absorption table (use "
                                 "scenesim.calibrate_room for per-band RT60 targets)")
        profile = None
        if self.absorption is not None:
            stored, profile = _check_absorption(self.absorption, self.bands_hz)
            object.__setattr__(self, "absorption", stored)
        if self.rt60_s is None:
            alpha = profile
        else:
            t = check_positive("rt60_s", self.rt60_s)
            object.__setattr__(self, "rt60_s", t)
            # The brief's feasibility rule for every method: Sabine alpha must not exceed 1.
            alpha_sabine = sabine_absorption(t, self.dims_m, c=self.c)
            if self.rt60_method == "sabine":
                alpha = np.full(6, alpha_sabine)
            elif self.rt60_method == "eyring":
                alpha = np.full(6, eyring_absorption(t, self.dims_m, c=self.c))
            else:
                if _calibrator is None:  # pragma: no cover - scenesim/room/__init__ registers one
                    raise ScenesimError("rt60_method='calibrated' needs scenesim.room.calibration imported")
                alpha = np.asarray(_calibrator(self.dims_m, t, absorption=profile, bands_hz=self.bands_hz,
                                               air=self.air, c=self.c, scattering=self.scattering), dtype=float)
        alpha = np.array(alpha, dtype=float)
        alpha.flags.writeable = False
        object.__setattr__(self, "_alpha", alpha)

    def _check_extras(self):
        if self.bands_hz is not None:
            from scenesim.room.bands import check_centers  # bands imports only rt60: no cycle

            object.__setattr__(self, "bands_hz", check_centers(self.bands_hz))
        if self.air is not None:
            from scenesim.room.air import AirAbsorption

            if not isinstance(self.air, AirAbsorption):
                raise ParameterError("air", self.air, "None or a scenesim.room.air.AirAbsorption")
        self._check_scattering()
        if self.target_rt60_s is not None:
            t = np.asarray(self.target_rt60_s, dtype=float)
            if t.ndim > 1 or not np.all(np.isfinite(t)) or np.any(t <= 0):
                raise ParameterError("target_rt60_s", self.target_rt60_s, "RT60 values > 0 s")
            object.__setattr__(self, "target_rt60_s", float(t) if t.ndim == 0 else tuple(map(float, t)))

    # ----------------------------------------------------------------- derived values
    def _check_scattering(self):
        if self.scattering is None:
            return
        s = np.asarray(self.scattering, dtype=float) if not isinstance(self.scattering, str) else None
        n_bands = None if self.bands_hz is None else len(self.bands_hz)
        shapes = [(), (6,)] + ([] if n_bands is None else [(n_bands,), (6, n_bands)])
        if s is None or s.shape not in shapes or not np.all(np.isfinite(s)) or np.any(s < 0) or np.any(s >= 1):
            raise ParameterError("scattering", self.scattering,
                                 "None, or a scattering coefficient in [0, 1): one, 6 per wall"
                                 + ("" if n_bands is None else f", {n_bands} per band or (6, {n_bands})"))
        if not np.any(s > 0):
            object.__setattr__(self, "scattering", None)
        elif s.ndim == 0:
            object.__setattr__(self, "scattering", float(s))
        elif s.ndim == 1:
            object.__setattr__(self, "scattering", tuple(float(v) for v in s))
        else:
            object.__setattr__(self, "scattering", tuple(tuple(float(v) for v in row) for row in s))

    def scattering_table(self, band: int | None = None) -> np.ndarray:
        """Scattering ``(6,)`` per wall of one band (index; None for flat rooms); zeros when specular."""
        if self.scattering is None:
            return np.zeros(6)
        s = np.asarray(self.scattering, dtype=float)
        if s.ndim == 0:
            return np.full(6, float(s))
        if s.ndim == 2:
            return s[:, 0 if band is None else int(band)].copy()
        if s.size == 6:  # per wall, as absorption (also when there are 6 bands)
            return s.copy()
        return np.full(6, s[0 if band is None else int(band)])

    @property
    def volume_m3(self) -> float:
        """Room volume in m^3."""
        return float(np.prod(self.dims_m))

    @property
    def surface_m2(self) -> float:
        """Total wall surface in m^2."""
        return float(np.sum(wall_areas(self.dims_m)))

    @property
    def is_flat(self) -> bool:
        """True when one image-source RIR renders the room (no bands, no air)."""
        return self.bands_hz is None and self.air is None

    @property
    def wall_absorption(self) -> np.ndarray:
        """Energy absorption ``(6,)`` per wall (``(6, n_bands)`` with ``bands_hz``)."""
        return np.array(self._alpha)

    @property
    def reflection(self) -> np.ndarray:
        """Pressure reflection coefficients ``(6,)``: ``sqrt(1 - alpha)`` (flat rooms only).

        Raises :class:`ParameterError` for a room with bands or air: a single image-source
        render would silently ignore them (use :func:`scenesim.room.render.room_rir`).
        """
        if not self.is_flat:
            raise ParameterError("room", self, "a flat room for image_source_rir (render rooms with "
                                 "bands or air by scenesim.room.render.room_rir)")
        return np.sqrt(1.0 - np.array(self._alpha))

    def band_room(self, band: int | None = None) -> ShoeBox:
        """The flat room of one band (``band`` index; None for a flat room with air)."""
        if self.bands_hz is None:
            alpha = self._alpha
        else:
            if band is None or not 0 <= int(band) < len(self.bands_hz):
                raise ParameterError("band", band, f"a band index in 0..{len(self.bands_hz) - 1}")
            alpha = self._alpha[:, int(band)]
        return ShoeBox(self.dims_m, tuple(float(v) for v in alpha), c=self.c,
                       min_wall_distance_m=self.min_wall_distance_m,
                       scattering=None if self.scattering is None else tuple(self.scattering_table(band)))

    def _band_rt60(self, formula) -> float | np.ndarray:
        if self.bands_hz is None:
            return formula(self.dims_m, self._alpha, c=self.c)
        return np.array([formula(self.dims_m, self._alpha[:, b], c=self.c) for b in range(len(self.bands_hz))])

    @property
    def sabine_rt60_s(self) -> float | np.ndarray:
        """Sabine RT60 (s) of the room's absorption (``(n_bands,)`` with bands; air not included)."""
        return self._band_rt60(sabine_rt60)

    @property
    def eyring_rt60_s(self) -> float | np.ndarray:
        """Eyring RT60 (s) of the room's absorption (``(n_bands,)`` with bands; air not included)."""
        return self._band_rt60(eyring_rt60)

    @property
    def nominal_rt60_s(self) -> float:
        """The target RT60 when given (``rt60_s``, else ``target_rt60_s``), else the Sabine RT60;
        the largest over bands (used for default RIR lengths)."""
        for t in (self.rt60_s, self.target_rt60_s):
            if t is not None:
                return float(np.max(t))
        return float(np.max(self.sabine_rt60_s))

    # ----------------------------------------------------------------- checks
    def check_inside(self, point_m, *, name: str = "position") -> np.ndarray:
        """Return ``point_m`` as a float ``(3,)`` array, or raise naming ``name``.

        Raises :class:`ParameterError` when the point is not 3 finite numbers, lies outside
        the room, or is closer than ``min_wall_distance_m`` to a wall.
        """
        p = np.asarray(point_m, dtype=float) if not isinstance(point_m, str) else None
        if p is None or p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ParameterError(name, point_m, "3 finite coordinates in metres")
        d = self.min_wall_distance_m
        dims = np.asarray(self.dims_m)
        if np.any(p < d) or np.any(p > dims - d):
            raise ParameterError(
                name,
                tuple(float(v) for v in p),
                f"a point inside the room {self.dims_m} at least {d:g} m from every wall",
            )
        return p



__all__ = ["RT60_METHODS", "ShoeBox", "register_calibrator"]
