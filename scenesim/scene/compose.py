"""Scenes as values, rendered to signal images at the mic pair (issue 2; algorithms.md 2, 4, 8).

A :class:`Scene` is a frozen description: mic pair, optional shoebox room, speech source,
noise sources, SNR and seed.  Rendering is split in two steps so that a sweep over SNRs
renders the geometry once:

1. :func:`render_images` -> :class:`SceneImages`: the speech image ``(2, n)``, the noise image
   ``(2, n)`` at unit gain (each noise source at its ``gain_db``, before SNR scaling), and the
   clean **reference** ``(1, n)``: speech as received at the reference mic (channel 0) by the
   direct path, time-aligned with the speech image.
2. :meth:`SceneImages.mix` -> :class:`RenderedScene`: noise scaled so that
   ``10 log10(P_speech / P_noise) = snr_db`` at channel 0 (thesis eq. 7.1; ``snr_mode``
   "total" or "active"), optional sensor self-noise added after the scaling.

Propagation:

* **Free field** (``room=None``) with ``far_field=True``: plane waves of unit amplitude
  (:func:`scenesim.scene.freefield.plane_wave`; distances are ignored, a bulk delay of d/(2c) makes
  every delay causal).  The reference is channel 0 of the speech image itself.
* Free field with ``far_field=False``: point sources, ``s(t - R/c) / (4 pi R)``; the reference
  is again channel 0 (in free field the direct path is all there is).
* **Room**: point sources through the image-source RIRs (:func:`scenesim.room.cache.cached_rir`;
  ``far_field`` is not used).  Reference ``"direct"``: the order-0 image alone (RIR with
  ``max_order=0``); ``"early50"``: the full RIR to channel 0 cut 50 ms after the direct
  path's arrival.  Both use the RIRs' time origin (t = 0 at emission), so the reference is
  aligned with the speech image.

Noise fields: ``"point"`` sources propagate like speech; ``"diffuse"`` and ``"incoherent"``
fields are generated at the mics directly (:mod:`scenesim.scene.noise_fields`), from the given
noise (mono, or two channels) or, when the signal is ``None``, from seeded white noise.
Randomness comes from ``Scene.seed`` only (one independent stream per noise source and one
for the sensor noise), so a scene renders to the same numbers every time.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import signal as sps

from scenesim.errors import ParameterError
from scenesim.room.cache import cached_rir, canonical, stable_hash
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.freefield import plane_wave, point_source
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS, MicPair
from scenesim.scene.mixing import (
    active_speech_power,
    bandlimit,
    check_band,
    noise_gain_from_powers,
    signal_power,
)
from scenesim.scene.noise_fields import (
    diffuse_noise,
    incoherent_noise,
    independent_channels,
    sensor_noise,
    wind_noise,
)
from scenesim.scene.noise_hall import hall_noise
from scenesim.scene.sensors import SensorModel
from scenesim.scene.thesis_farfield import ThesisFarField, thesis_plane_wave
from scenesim.validate import (
    check_choice,
    check_finite_number,
    check_fs,
    check_int,
    check_positive,
    check_range,
)

SCENE_FORMAT = "scenesim-scene-v2"
"""Part of every scene key; bumped when rendering changes its numbers."""

NOISE_FIELDS = ("point", "diffuse", "incoherent", "wind", "spread", "hall")
"""Noise field types: a point source; spherically isotropic; spatially white; wind with the
Corcos coherence; ``n_sources`` point sources spread around the pair (babble in a room);
``n_sources`` machines in a reverberant factory hall (:mod:`scenesim.scene.noise_hall`)."""
SNR_MODES = ("total", "active")
REFERENCES = ("direct", "early50")
EARLY_REFERENCE_S = 0.05
"""Length of the early part kept after the direct path by ``reference="early50"``."""

_NOISE_STREAM = 1
_SENSOR_STREAM = 2
_SPREAD_STREAM = 3
_SELF_NOISE_STREAM = 4
#: A "spread" source keeps at least this far from the pair centre (m) and from the walls.
SPREAD_MIN_DISTANCE_M = 0.5
SPREAD_WALL_MARGIN_M = 0.2


def _check_position(name: str, value):
    if value is None:
        return None
    p = np.asarray(value, dtype=float) if not isinstance(value, str) else None
    if p is None or p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ParameterError(name, value, "None or 3 finite coordinates in metres")
    return tuple(float(v) for v in p)


class _Placed:
    """Shared placement logic of :class:`SourcePlacement` and :class:`NoiseSource`."""

    def _validate_placement(self):
        object.__setattr__(
            self, "azimuth_deg", check_finite_number("azimuth_deg", self.azimuth_deg)
        )
        object.__setattr__(self, "distance_m", check_positive("distance_m", self.distance_m))
        object.__setattr__(
            self, "elevation_deg", check_range("elevation_deg", self.elevation_deg, -90.0, 90.0)
        )
        object.__setattr__(self, "position_m", _check_position("position_m", self.position_m))

    def position(self, pair: MicPair) -> np.ndarray:
        """Absolute position ``(3,)`` in metres for this pair."""
        if self.position_m is not None:
            return np.asarray(self.position_m)
        return pair.source_position(self.azimuth_deg, self.distance_m, self.elevation_deg)

    def direction(self, pair: MicPair) -> tuple[float, float]:
        """Array-relative ``(azimuth_deg, elevation_deg)`` seen from the pair centre."""
        if self.position_m is None:
            return self.azimuth_deg, self.elevation_deg
        v = np.asarray(self.position_m) - np.asarray(pair.center_m)
        r = float(np.linalg.norm(v))
        if np.hypot(v[0], v[1]) == 0.0:
            raise ParameterError(
                "position_m", self.position_m, "a point off the vertical through the pair centre"
            )
        return pair.azimuth_of(self.position_m), float(np.rad2deg(np.arcsin(v[2] / r)))


@dataclass(frozen=True)
class SourcePlacement(_Placed):
    """Where a source is: array-relative angles and distance, or an absolute position.

    Parameters
    ----------
    azimuth_deg : float
        Azimuth from the array axis (endfire = 0 deg), counter-clockwise.
    distance_m : float
        Distance from the pair centre in metres (> 0; unused by far-field plane waves).
    elevation_deg : float
        Elevation above the horizontal plane, in [-90, 90].
    position_m : 3 floats, optional
        Absolute position in metres; when given it takes precedence over the angles.
    """

    azimuth_deg: float = 45.0
    distance_m: float = 1.0
    elevation_deg: float = 0.0
    position_m: tuple[float, float, float] | None = None

    def __post_init__(self):
        self._validate_placement()


@dataclass(frozen=True)
class NoiseSource(_Placed):
    """A noise source: a point source placed like speech, or a diffuse/incoherent field.

    Parameters
    ----------
    field : {"point", "diffuse", "incoherent", "wind", "spread", "hall"}
        Point source (propagated like speech); spherically isotropic field; spatially
        incoherent noise; wind turbulence with the Corcos coherence
        (:func:`scenesim.scene.noise_fields.wind_noise`); or ``n_sources`` point sources at seeded
        random places (in a room: anywhere at least 0.5 m from the pair and 0.2 m from the
        walls; in free field: plane waves from random directions), each playing its own
        excerpt of the noise -- babble from talkers spread around a room; or ``n_sources``
        machines in a reverberant hall of their own (:mod:`scenesim.scene.noise_hall`).  The
        placement is used by "point" only.
    azimuth_deg, distance_m, elevation_deg, position_m
        As in :class:`SourcePlacement` (default: 270 deg, broadside, 1 m).
    gain_db : float
        Level of this source relative to the others in the scene's noise image.
    wind_speed_mps, flow_azimuth_deg : float
        "wind" only: wind speed (m/s) and the flow direction re the array axis (deg).
    n_sources : int
        "spread" and "hall" only: how many sources.
    """

    field: str = "point"
    azimuth_deg: float = 270.0
    distance_m: float = 1.0
    elevation_deg: float = 0.0
    gain_db: float = 0.0
    position_m: tuple[float, float, float] | None = None
    wind_speed_mps: float = 5.0
    flow_azimuth_deg: float = 0.0
    n_sources: int = 8

    def __post_init__(self):
        check_choice("field", self.field, NOISE_FIELDS)
        self._validate_placement()
        object.__setattr__(self, "gain_db", check_finite_number("gain_db", self.gain_db))
        object.__setattr__(
            self, "wind_speed_mps", check_range("wind_speed_mps", self.wind_speed_mps, 0.1, 50.0)
        )
        object.__setattr__(
            self, "flow_azimuth_deg", check_finite_number("flow_azimuth_deg", self.flow_azimuth_deg)
        )
        object.__setattr__(self, "n_sources", check_int("n_sources", self.n_sources, minimum=1, maximum=64))


@dataclass(frozen=True)
class Scene:
    """A complete, hashable description of one acoustic condition.

    Parameters
    ----------
    fs : int
        Sampling rate in Hz.
    pair : MicPair
        The array (channel 0 = front = reference mic).
    room : ShoeBox, optional
        None: anechoic free field.
    speech : SourcePlacement
        Where the talker is (default 45 deg, 1 m).
    noises : tuple of NoiseSource
        Noise sources (default one point source at 270 deg, 1 m); may be empty.
    snr_db : float
        Target SNR at the reference mic (used by :func:`render_scene`).
    far_field : bool
        Free field only: plane waves (True) or point sources (False).
    snr_mode : {"total", "active"}
        Speech power over the whole signal or its P.56-style active level.
    reference : {"direct", "early50"}
        Reference signal in a room: direct path, or direct path + first 50 ms.
    sensor_noise_db : float, optional
        Legacy: white sensor noise power relative to the speech power at the reference mic
        (dB).  Physical sensors are ``sensors`` (self-noise in dBA SPL against a speech level).
    sensors : SensorModel, optional
        The mics' responses and self-noise (:mod:`scenesim.scene.sensors`); None = ideal sensors.
    snr_band_hz : (lo, hi), optional
        Set the SNR from the powers in this band (Hz) instead of the full band: a 0 dB wind
        whose power lies below 100 Hz is not a 0 dB condition for speech.
    thesis_far_field : ThesisFarField, optional
        Free field with ``far_field=True`` only: render point sources by the source thesis'
        own model (truncated-sinc delays about the pair midpoint, its angle convention;
        :mod:`scenesim.scene.thesis_farfield`) instead of exact plane waves.
    max_order : int, optional
        Image-source order bound in a room (None: all images within the RIR length).
    seed : int
        Seed of every random draw of the rendering.

    Raises
    ------
    ParameterError
        A bad value, or (in a room) a mic or a point source outside the room / too close
        to a wall.
    """

    fs: int = 16000
    pair: MicPair = field(default_factory=MicPair)
    room: ShoeBox | None = None
    speech: SourcePlacement = field(default_factory=SourcePlacement)
    noises: tuple[NoiseSource, ...] = (NoiseSource(),)
    snr_db: float = 0.0
    far_field: bool = True
    snr_mode: str = "total"
    reference: str = "direct"
    sensor_noise_db: float | None = None
    max_order: int | None = None
    seed: int = 0
    sensors: SensorModel | None = None
    snr_band_hz: tuple[float, float] | None = None
    thesis_far_field: ThesisFarField | None = None

    def __post_init__(self):
        object.__setattr__(self, "fs", check_fs(self.fs))
        if not isinstance(self.pair, MicPair):
            raise ParameterError("pair", self.pair, "a scenesim.scene.geometry.MicPair")
        if self.room is not None and not isinstance(self.room, ShoeBox):
            raise ParameterError("room", self.room, "None or a scenesim.room.shoebox.ShoeBox")
        if not isinstance(self.speech, SourcePlacement):
            raise ParameterError("speech", self.speech, "a SourcePlacement")
        if isinstance(self.noises, NoiseSource) or not isinstance(self.noises, Sequence):
            raise ParameterError("noises", self.noises, "a tuple of NoiseSource")
        noises = tuple(self.noises)
        for k, n in enumerate(noises):
            if not isinstance(n, NoiseSource):
                raise ParameterError(f"noises[{k}]", n, "a NoiseSource")
        object.__setattr__(self, "noises", noises)
        object.__setattr__(self, "snr_db", check_finite_number("snr_db", self.snr_db))
        if not isinstance(self.far_field, (bool, np.bool_)):
            raise ParameterError("far_field", self.far_field, "True or False")
        object.__setattr__(self, "far_field", bool(self.far_field))
        check_choice("snr_mode", self.snr_mode, SNR_MODES)
        check_choice("reference", self.reference, REFERENCES)
        if self.sensor_noise_db is not None:
            object.__setattr__(
                self,
                "sensor_noise_db",
                check_finite_number("sensor_noise_db", self.sensor_noise_db),
            )
        if self.max_order is not None:
            object.__setattr__(self, "max_order", check_int("max_order", self.max_order, minimum=0))
        object.__setattr__(self, "seed", check_int("seed", self.seed, minimum=0))
        if self.sensors is not None:
            if not isinstance(self.sensors, SensorModel):
                raise ParameterError("sensors", self.sensors, "None or a scenesim.scene.sensors.SensorModel")
            if len(self.sensors.mics) != 2:
                raise ParameterError("sensors", self.sensors, "a SensorModel with 2 mics (front, rear)")
            for m in self.sensors.mics:
                m.highpass_ba(self.fs)  # a corner at or above fs/2 raises here, not mid-render
        if self.snr_band_hz is not None:
            object.__setattr__(self, "snr_band_hz", check_band(self.snr_band_hz, fs=self.fs))
        if self.thesis_far_field is not None and not isinstance(self.thesis_far_field, ThesisFarField):
            raise ParameterError("thesis_far_field", self.thesis_far_field, "None or a ThesisFarField")
        if self.room is not None:
            self._check_geometry_in_room()
        else:
            self._check_free_field_geometry()

    def _check_geometry_in_room(self):
        room = self.room
        room.check_inside(self.pair.center_m, name="pair.center_m")
        for k, p in enumerate(self.pair.positions_m):
            room.check_inside(p, name=f"pair.positions_m[{k}]")
        room.check_inside(self.speech.position(self.pair), name="speech.position_m")
        for k, n in enumerate(self.noises):
            if n.field == "point":
                room.check_inside(n.position(self.pair), name=f"noises[{k}].position_m")

    def _check_free_field_geometry(self):
        # Point sources must not sit on a mic (1/(4 pi R) would blow up).
        sources = [("speech", self.speech)] + [
            (f"noises[{k}]", n) for k, n in enumerate(self.noises) if n.field == "point"
        ]
        for name, src in sources:
            if self.far_field:
                src.direction(self.pair)  # raises for a position on the pair centre
                continue
            dist = np.linalg.norm(self.pair.positions_m - src.position(self.pair)[None, :], axis=1)
            if np.any(dist < 1e-3):
                raise ParameterError(
                    f"{name}.position_m", src.position_m, "a point >= 1 mm from every mic"
                )

    @property
    def speed_of_sound_mps(self) -> float:
        """``room.c`` in a room, else 343 m/s."""
        return self.room.c if self.room is not None else SPEED_OF_SOUND_MPS

    def to_dict(self) -> dict:
        """Plain JSON-ready nested dict of every parameter (what :meth:`key` hashes)."""
        return canonical(self)

    def key(self) -> str:
        """Stable hex sha256 of the canonical JSON of every parameter (same across processes)."""
        return stable_hash({"format": SCENE_FORMAT, "scene": self})


def _freeze(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class RenderedScene:
    """One scene mixed at one SNR; all arrays float64 ``(n_channels, n)``, freshly allocated.

    ``mixture = speech_image + noise_image``; ``noise_image`` is the scaled acoustic noise
    plus the sensors' self-noise (``self_noise_image``, also kept on its own; zeros for
    noiseless sensors); ``noise_gain`` the amplitude factor applied to the unit-gain
    noise image; ``reference`` ``(1, n)`` the clean speech at channel 0 (direct path),
    through the front mic's response like the images.
    """

    mixture: np.ndarray
    speech_image: np.ndarray
    noise_image: np.ndarray
    reference: np.ndarray
    fs: int
    snr_db: float
    noise_gain: float
    scene: Scene
    self_noise_image: np.ndarray | None = None


@dataclass(frozen=True)
class SceneImages:
    """Speech and unit-gain noise images of a scene, ready to be mixed at any SNR.

    Attributes
    ----------
    speech_image : ndarray (2, n)
    noise_image : ndarray (2, n)
        Sum of the noise sources, each at its ``gain_db``; before SNR scaling.  Both
        images are what the mics output: through ``scene.sensors``' responses.
    reference : ndarray (1, n)
        Clean speech at the reference mic by the direct path (see the module docstring).
    fs : int
    rirs : dict of str -> ndarray
        Room RIRs used: ``"speech"`` (2, taps), ``"speech_reference"`` (1, taps), and
        ``"noise{k}"`` for point noise k.  Empty in free field.
    scene : Scene

    The arrays are read-only: mixing at many SNRs never alters them.
    """

    speech_image: np.ndarray
    noise_image: np.ndarray
    reference: np.ndarray
    fs: int
    rirs: Mapping[str, np.ndarray]
    scene: Scene
    acoustic_speech: np.ndarray | None = None

    def _power(self, x: np.ndarray, *, speech: bool) -> float:
        band = self.scene.snr_band_hz
        if band is not None:
            x = bandlimit(x, self.fs, band)
        if speech and self.scene.snr_mode == "active":
            return active_speech_power(x, self.fs)
        return signal_power(x)

    @functools.cached_property
    def speech_power(self) -> float:
        """Speech power at channel 0 by ``scene.snr_mode``, in ``scene.snr_band_hz`` if set
        (computed once, reused by every mix)."""
        return self._power(self.speech_image[0], speech=True)

    @functools.cached_property
    def noise_power(self) -> float:
        """Mean square of the unit-gain noise image at channel 0 (in ``scene.snr_band_hz`` if set)."""
        return self._power(self.noise_image[0], speech=False)

    @functools.cached_property
    def speech_level_power(self) -> float:
        """Power of the *acoustic* speech at the reference mic (before the mic's response, full
        band, by ``snr_mode``): the digital power that stands for ``sensors.speech_spl_db``."""
        x = self.speech_image[0] if self.acoustic_speech is None else self.acoustic_speech
        if self.scene.snr_mode == "active":
            return active_speech_power(x, self.fs)
        return signal_power(x)

    def self_noise(self) -> np.ndarray:
        """The sensors' self-noise ``(2, n)`` (seeded by the scene; zeros without sensors)."""
        sensors = self.scene.sensors
        n = self.speech_image.shape[1]
        if sensors is None or sensors.self_noise_dba is None:
            return np.zeros((2, n))
        rng = np.random.default_rng([self.scene.seed, _SELF_NOISE_STREAM])
        return sensors.self_noise(n, speech_power=self.speech_level_power, fs=self.fs, rng=rng)

    def mix(self, snr_db: float | None = None) -> RenderedScene:
        """Scale the noise to ``snr_db`` (default ``scene.snr_db``) at channel 0 and add it.

        Sensor self-noise (``scene.sensors.self_noise_dba`` against
        ``scene.sensors.speech_spl_db``, or the legacy ``scene.sensor_noise_db`` re the speech
        power) is added after the scaling, so with self-noise the SNR is slightly below the
        target; it is part of ``noise_image`` and also returned as ``self_noise_image``.
        A scene without noise sources gets gain 0 (clean mixture, plus sensor noise).
        """
        scene = self.scene
        snr = scene.snr_db if snr_db is None else check_finite_number("snr_db", snr_db)
        if scene.noises:
            if self.noise_power <= 0.0:
                raise ParameterError("noise_signals", "silent noise", "noise with non-zero power")
            # Thesis eq. 7.1, as in noise_gain_for_snr, with the powers computed once.
            gain = noise_gain_from_powers(self.speech_power, self.noise_power, snr)
        else:
            gain = 0.0
        noise = gain * self.noise_image
        self_noise = self.self_noise()
        if scene.sensor_noise_db is not None:
            level = 10.0 * np.log10(self.speech_power) + scene.sensor_noise_db
            rng = np.random.default_rng([scene.seed, _SENSOR_STREAM])
            self_noise = self_noise + sensor_noise(
                noise.shape[1], n_channels=noise.shape[0], level_db=level, rng=rng
            )
        noise = noise + self_noise
        return RenderedScene(
            mixture=self.speech_image + noise,
            speech_image=self.speech_image.copy(),
            noise_image=noise,
            reference=self.reference.copy(),
            fs=self.fs,
            snr_db=snr,
            noise_gain=float(gain),
            scene=scene,
            self_noise_image=self_noise,
        )


def _mono(x, name: str) -> np.ndarray:
    arr = np.asarray(x)
    if arr.ndim == 2 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 1 or arr.dtype.kind not in "fiu":
        raise ParameterError(name, arr, "a mono signal shaped (n_samples,)")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "finite values only (no NaN or Inf)")
    return arr


def _convolve(x: np.ndarray, h: np.ndarray, n: int) -> np.ndarray:
    """``x`` (n,) convolved with every row of ``h`` (m, taps), cut to ``n`` samples."""
    return sps.oaconvolve(x[None, :], h, mode="full", axes=1)[:, :n]


def _render_point(scene: Scene, x: np.ndarray, src: SourcePlacement, label: str, rirs: dict):
    """Image ``(2, n)`` and reference ``(1, n)`` of a point source (speech or point noise)."""
    pair, fs, c, n = scene.pair, scene.fs, scene.speed_of_sound_mps, x.size
    if scene.room is None:
        if scene.far_field and scene.thesis_far_field is not None:
            img = thesis_plane_wave(x, pair, azimuth_deg=src.direction(pair)[0], fs=fs, c=c,
                                    model=scene.thesis_far_field)
        elif scene.far_field:
            az, el = src.direction(pair)
            img = plane_wave(x, pair, azimuth_deg=az, elevation_deg=el, fs=fs, c=c)
        else:
            img = point_source(x, pair, position_m=src.position(pair), fs=fs, c=c)
        return img, img[:1].copy()
    pos = src.position(pair)
    h = cached_rir(scene.room, pos, pair.positions_m, fs=fs, max_order=scene.max_order)
    rirs[label] = h
    img = _convolve(x, h, n)
    if label != "speech":
        return img, None
    if scene.reference == "direct":
        h_ref = cached_rir(scene.room, pos, pair.positions_m[:1], fs=fs, max_order=0)
    else:
        r0 = float(np.linalg.norm(pair.positions_m[0] - pos))
        cut = int(np.ceil((r0 / c + EARLY_REFERENCE_S) * fs))
        h_ref = h[:1, :cut]
    rirs[label + "_reference"] = h_ref
    return img, _convolve(x, h_ref, n)


def _noise_input(sig, k: int, n: int, field_name: str) -> np.ndarray | None:
    name = f"noise_signals[{k}]"
    if sig is None:
        return None
    arr = np.asarray(sig)
    if field_name == "point" or arr.ndim == 1:
        arr = _mono(arr, name)[None, :]
    elif arr.ndim != 2 or arr.shape[0] not in (1, 2):
        raise ParameterError(name, arr, "a mono (n,) or two-channel (2, n) noise")
    if arr.dtype.kind not in "fiu" or not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "finite real values")
    if arr.shape[1] < n:
        raise ParameterError(name, arr, f"at least {n} samples (the speech length)")
    return arr.astype(np.float64, copy=False)


def render_images(scene: Scene, speech, noise_signals: Sequence = ()) -> SceneImages:
    """Render the speech image, the unit-gain noise image and the reference of a scene.

    Parameters
    ----------
    scene : Scene
    speech : array (n,)
        Clean speech (the source signal); the output length is ``n``.
    noise_signals : sequence, one per ``scene.noises``
        Each ``(n_noise,)`` mono, or ``(2, n_noise)`` for a diffuse/incoherent field given
        as two independent channels, with ``n_noise >= n`` (longer ones are cut; a diffuse
        field from a mono noise uses a second, disjoint part of it when long enough).
        ``None`` draws seeded white Gaussian noise.

    Returns
    -------
    SceneImages
    """
    if not isinstance(scene, Scene):
        raise ParameterError("scene", scene, "a scenesim.scene.compose.Scene")
    s = _mono(speech, "speech")
    if not np.any(s):
        raise ParameterError("speech", s, "a signal with non-zero power")
    n = s.size
    if isinstance(noise_signals, np.ndarray) or not isinstance(noise_signals, Sequence):
        raise ParameterError(
            "noise_signals", noise_signals, "a sequence with one signal per noise source"
        )
    if len(noise_signals) != len(scene.noises):
        raise ParameterError(
            "noise_signals",
            f"{len(noise_signals)} signal(s)",
            f"{len(scene.noises)}, one per NoiseSource",
        )
    rirs: dict[str, np.ndarray] = {}
    speech_image, reference = _render_point(scene, s, scene.speech, "speech", rirs)
    noise_image = np.zeros((2, n))
    for k, (src, sig) in enumerate(zip(scene.noises, noise_signals)):
        img = _render_noise(scene, src, k, _noise_input(sig, k, n, src.field), n, rirs)
        noise_image += 10.0 ** (src.gain_db / 20.0) * img
    acoustic_speech = None
    if scene.sensors is not None and not scene.sensors.linear_ideal:
        # What the mics output; linear, so every component goes through the same responses.
        acoustic_speech = _freeze(speech_image[0])
        speech_image = scene.sensors.apply(speech_image, fs=scene.fs)
        noise_image = scene.sensors.apply(noise_image, fs=scene.fs)
        reference = scene.sensors.mics[0].apply(reference, fs=scene.fs)
    return SceneImages(
        speech_image=_freeze(speech_image),
        noise_image=_freeze(noise_image),
        reference=_freeze(reference),
        fs=scene.fs,
        rirs={k: _freeze(v) for k, v in rirs.items()},
        scene=scene,
        acoustic_speech=acoustic_speech,
    )


def _render_noise(scene: Scene, src: NoiseSource, k: int, arr, n: int, rirs: dict) -> np.ndarray:
    """The unit-gain ``(2, n)`` image of noise source ``k`` (its field decides how), seeded per source."""
    rng = np.random.default_rng([scene.seed, _NOISE_STREAM, k])
    if src.field == "point":
        mono = rng.standard_normal(n) if arr is None else arr[0, :n]
        return _render_point(scene, mono, src, f"noise{k}", rirs)[0]
    if src.field == "diffuse":
        return diffuse_noise(
            n, scene.pair, fs=scene.fs, rng=rng, c=scene.speed_of_sound_mps, source=arr
        )
    if src.field == "wind":
        return wind_noise(
            n,
            scene.pair,
            fs=scene.fs,
            wind_speed_mps=src.wind_speed_mps,
            flow_azimuth_deg=src.flow_azimuth_deg,
            rng=rng,
            source=arr,
        )
    if src.field == "spread":
        return _render_spread(scene, src, k, n, arr, rng, rirs)
    if src.field == "hall":
        machines = independent_channels(n, n_channels=src.n_sources, rng=rng, source=None if arr is None else arr[0])
        return hall_noise(machines, scene.pair, fs=scene.fs, seed=scene.seed, c=scene.speed_of_sound_mps)
    return incoherent_noise(n, rng=rng, source=arr)


def spread_positions(scene: Scene, src: NoiseSource, k: int) -> np.ndarray:
    """Positions ``(n_sources, 3)`` of a "spread" noise in a room, or unit directions in free field.

    Seeded by ``(scene.seed, k)``.  In a room: uniform in the room shrunk by
    :data:`SPREAD_WALL_MARGIN_M`, redrawn while closer than :data:`SPREAD_MIN_DISTANCE_M` to
    the pair centre.  In free field: directions uniform on the sphere.
    """
    rng = np.random.default_rng([scene.seed, _SPREAD_STREAM, k])
    if scene.room is None:
        v = rng.standard_normal((src.n_sources, 3))
        return v / np.linalg.norm(v, axis=1, keepdims=True)
    dims = np.asarray(scene.room.dims_m, dtype=float)
    lo, hi = np.full(3, SPREAD_WALL_MARGIN_M), dims - SPREAD_WALL_MARGIN_M
    center = np.asarray(scene.pair.center_m)
    out = []
    for _ in range(1000 * src.n_sources):
        p = rng.uniform(lo, hi)
        if np.linalg.norm(p - center) >= SPREAD_MIN_DISTANCE_M:
            out.append(p)
            if len(out) == src.n_sources:
                return np.asarray(out)
    raise ParameterError(
        "room", scene.room.dims_m, f"a room with space for sources >= {SPREAD_MIN_DISTANCE_M} m from the pair"
    )


def _render_spread(scene: Scene, src: NoiseSource, k: int, n: int, arr, rng, rirs: dict) -> np.ndarray:
    """Image ``(2, n)`` of ``n_sources`` point sources, each with its own noise excerpt."""
    signals = independent_channels(
        n, n_channels=src.n_sources, rng=rng, source=None if arr is None else arr[0]
    )
    where = spread_positions(scene, src, k)
    img = np.zeros((2, n))
    for j, (sig, p) in enumerate(zip(signals, where)):
        if scene.room is None:
            az = float(np.rad2deg(np.arctan2(p[1], p[0])) - scene.pair.axis_azimuth_deg)
            el = float(np.rad2deg(np.arcsin(np.clip(p[2], -1.0, 1.0))))
            img += plane_wave(sig, scene.pair, azimuth_deg=az, elevation_deg=el, fs=scene.fs, c=scene.speed_of_sound_mps)
        else:
            part, _ = _render_point(scene, sig, SourcePlacement(position_m=tuple(p)), f"noise{k}.{j}", rirs)
            img += part
    return img


def render_scene(scene: Scene, speech, noise_signals: Sequence = ()) -> RenderedScene:
    """``render_images(scene, speech, noise_signals).mix(scene.snr_db)``."""
    return render_images(scene, speech, noise_signals).mix(scene.snr_db)
