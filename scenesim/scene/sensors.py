"""Real microphones: sensitivity, phase and high-pass mismatch, self-noise (algorithms.md 4b).

A phone's MEMS pair is not two identical ideal pressure sensors.  Per microphone ``i``
this module models the linear response

``H_i(f) = 10^(g_i / 20) * exp(j phi_i sgn f) * j f / (f_ci + j f)``

* ``g_i`` -- sensitivity in dB re nominal (datasheets: +-1 dB untrimmed);
* ``phi_i`` -- a frequency-independent phase offset in degrees (not a physical mechanism:
  a worst-case knob for tests; applied exactly in the frequency domain, i.e. circularly
  over the signal, through the analytic signal ``x cos phi - Hilbert(x) sin phi``);
* ``f_ci`` -- the corner of a first-order high-pass (acoustic port + ADC high-pass,
  50-150 Hz on phones).  Unequal corners are the realistic source of low-frequency phase
  mismatch, ``atan(f_c1 / f) - atan(f_c2 / f)``.  It is the bilinear transform of the
  analog section with the corner pre-warped (``scipy.signal.butter(1, fc, "highpass")``),
  run causally, so its response is exactly that digital filter's.

and an additive **self-noise**: each mic's equivalent input noise as an A-weighted level in
dB SPL (a 64 dB-SNR MEMS mic: 94 - 64 = 30 dBA), spatially white, independent between the
mics, with a **white** spectrum (MEMS self-noise is close to white over the speech band; its
1/f rise lies below ~100 Hz where A-weighting removes it).  It is added at each mic's output
after the linear response, at the nominal sensitivity (datasheets quote it that way).

Self-noise is only physical against a speech level: ``speech_spl_db`` is the talker's level
in dB SPL at the reference mic (hands-free speech at a phone: about 57-66 dBA; default 65).
The digital scale follows from it: the speech image's power at channel 0 *is* that level,
so a white self-noise of variance ``sigma^2`` has A-weighted level
``L_s + 10 log10(sigma^2 * mean_f |A(f)|^2 / P_s)`` and :func:`self_noise_variance`
inverts that.

Everything here is linear and time-invariant, so it is applied identically to the mixture
and to every component (speech image, noise image) and shadow-filter replay stays exact.

Example
-------
>>> import numpy as np
>>> from scenesim.scene.sensors import MicResponse, SensorModel
>>> model = SensorModel.from_mismatch(gain_db=0.5, phase_deg=2.0, highpass_hz=(80.0, 120.0))
>>> y = model.apply(np.random.default_rng(0).standard_normal((2, 1600)), fs=16000)
>>> y.shape
(2, 1600)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import signal as sps
from scipy.integrate import trapezoid

from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_fs, check_positive, check_range

#: Reference sound pressure for dB SPL, in pascal.
P_REF_PA = 20e-6
#: A MEMS microphone's datasheet SNR is quoted re 94 dB SPL (1 Pa) at 1 kHz.
SNR_REFERENCE_SPL_DB = 94.0
#: Default talker level at the reference mic for hands-free use, dB SPL.
DEFAULT_SPEECH_SPL_DB = 65.0
#: Highest phase offset accepted (a worst-case knob, not a physical mismatch).
MAX_PHASE_DEG = 90.0


def a_weighting_db(freqs_hz) -> np.ndarray:
    """IEC 61672-1 A-weighting in dB (0 dB at 1 kHz; ``-inf`` at 0 Hz).

    ``R_A(f) = 12194^2 f^4 / ((f^2 + 20.6^2) sqrt((f^2 + 107.7^2)(f^2 + 737.9^2)) (f^2 + 12194^2))``,
    ``A(f) = 20 log10 R_A(f) + 2.00``.

    >>> round(float(a_weighting_db([1000.0])[0]), 2)
    0.0
    """
    f2 = np.asarray(freqs_hz, dtype=float) ** 2
    num = 12194.0**2 * f2**2
    den = (f2 + 20.6**2) * np.sqrt((f2 + 107.7**2) * (f2 + 737.9**2)) * (f2 + 12194.0**2)
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(num / den) + 2.0


def a_weighted_white_fraction(fs: int) -> float:
    """``mean |A(f)|^2`` over 0..fs/2: the A-weighted power of unit-variance white noise.

    A fine uniform grid (the integrand is smooth) so the number does not depend on a
    signal length.
    """
    f = np.linspace(0.0, check_fs(fs) / 2.0, 200_001)
    w = 10.0 ** (a_weighting_db(f) / 10.0)
    return float(trapezoid(w, f) / f[-1])


def self_noise_variance(self_noise_dba: float, *, speech_spl_db: float, speech_power: float, fs: int) -> float:
    """Variance (digital units^2) of white self-noise at ``self_noise_dba`` re the speech level.

    The speech at the reference mic has power ``speech_power`` (digital) and level
    ``speech_spl_db``; a white noise of variance ``v`` has A-weighted level
    ``speech_spl_db + 10 log10(v * a_weighted_white_fraction(fs) / speech_power)``.

    >>> v = self_noise_variance(30.0, speech_spl_db=65.0, speech_power=1.0, fs=16000)
    >>> round(float(10 * np.log10(v * a_weighted_white_fraction(16000))), 6)
    -35.0
    """
    level = check_finite_number("self_noise_dba", self_noise_dba)
    spl = check_finite_number("speech_spl_db", speech_spl_db)
    power = check_positive("speech_power", speech_power)
    return power * 10.0 ** ((level - spl) / 10.0) / a_weighted_white_fraction(fs)


@dataclass(frozen=True)
class MicResponse:
    """One microphone's linear response (see the module docstring).

    Parameters
    ----------
    gain_db : float
        Sensitivity re nominal, dB (``|gain| <= 20``).
    phase_deg : float
        Frequency-independent phase offset, degrees (``|phase| <= 90``).
    highpass_hz : float
        Corner of the first-order high-pass in Hz; 0 = none.

    >>> MicResponse(gain_db=1.0).ideal
    False
    """

    gain_db: float = 0.0
    phase_deg: float = 0.0
    highpass_hz: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "gain_db", check_range("gain_db", self.gain_db, -20.0, 20.0))
        object.__setattr__(
            self, "phase_deg", check_range("phase_deg", self.phase_deg, -MAX_PHASE_DEG, MAX_PHASE_DEG)
        )
        object.__setattr__(
            self, "highpass_hz", check_positive("highpass_hz", self.highpass_hz, allow_zero=True)
        )

    @property
    def ideal(self) -> bool:
        """True for the identity response."""
        return self.gain_db == 0.0 and self.phase_deg == 0.0 and self.highpass_hz == 0.0

    def highpass_ba(self, fs: int) -> tuple[np.ndarray, np.ndarray] | None:
        """``(b, a)`` of the digital first-order high-pass, or None without one."""
        if self.highpass_hz == 0.0:
            return None
        fs = check_fs(fs)
        if self.highpass_hz >= fs / 2:
            raise ParameterError("highpass_hz", self.highpass_hz, f"a corner below fs/2 = {fs / 2:g} Hz")
        b, a = sps.butter(1, self.highpass_hz, btype="highpass", fs=fs)
        return b, a

    def frequency_response(self, freqs_hz, *, fs: int) -> np.ndarray:
        """Complex response ``H(f)`` at ``freqs_hz`` (>= 0) of what :meth:`apply` does."""
        f = np.asarray(freqs_hz, dtype=float)
        h = 10.0 ** (self.gain_db / 20.0) * np.exp(1j * np.deg2rad(self.phase_deg) * np.sign(f))
        ba = self.highpass_ba(fs)
        if ba is not None:
            _, hp = sps.freqz(ba[0], ba[1], worN=f, fs=fs)
            h = h * hp
        return h

    def apply(self, x: np.ndarray, *, fs: int) -> np.ndarray:
        """This response applied to each row of ``x`` ``(n_rows, n)`` (a new array)."""
        y = np.array(x, dtype=np.float64, copy=True)
        if self.phase_deg != 0.0:
            phi = np.deg2rad(self.phase_deg)
            # Re{e^{j phi} (x + j H{x})} = x cos(phi) - H{x} sin(phi): X(f) e^{j phi sgn f}.
            y = np.real(sps.hilbert(y, axis=-1) * np.exp(1j * phi))
        if self.gain_db != 0.0:
            y = y * 10.0 ** (self.gain_db / 20.0)
        ba = self.highpass_ba(fs)
        if ba is not None:
            y = sps.lfilter(ba[0], ba[1], y, axis=-1)
        return y


def _two_corners(value) -> tuple[float, float]:
    if value is None:
        return (0.0, 0.0)
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        v = check_positive("mic_highpass_hz", value, allow_zero=True)
        return (v, v)
    items = tuple(value)
    if len(items) != 2:
        raise ParameterError("mic_highpass_hz", value, "one corner in Hz or [front, rear]")
    return tuple(check_positive("mic_highpass_hz", v, allow_zero=True) for v in items)


@dataclass(frozen=True)
class SensorModel:
    """The pair's sensors: one :class:`MicResponse` per mic (front, rear) and self-noise.

    Parameters
    ----------
    mics : tuple of MicResponse
        One per channel (channel 0 = front = reference mic).
    self_noise_dba : float or None
        Equivalent input self-noise of every mic in dBA SPL; None = noiseless sensors.
    speech_spl_db : float
        Talker level at the reference mic in dB SPL (only matters with self-noise).

    >>> SensorModel().ideal
    True
    """

    mics: tuple[MicResponse, ...] = field(default=(MicResponse(), MicResponse()))
    self_noise_dba: float | None = None
    speech_spl_db: float = DEFAULT_SPEECH_SPL_DB

    def __post_init__(self):
        mics = tuple(self.mics)
        if not mics or not all(isinstance(m, MicResponse) for m in mics):
            raise ParameterError("mics", self.mics, "a tuple of MicResponse, one per mic")
        object.__setattr__(self, "mics", mics)
        if self.self_noise_dba is not None:
            object.__setattr__(
                self, "self_noise_dba", check_range("self_noise_dba", self.self_noise_dba, -20.0, 120.0)
            )
        object.__setattr__(
            self, "speech_spl_db", check_range("speech_spl_db", self.speech_spl_db, 0.0, 140.0)
        )

    @classmethod
    def from_mismatch(
        cls,
        *,
        gain_db: float = 0.0,
        phase_deg: float = 0.0,
        highpass_hz: float | Sequence[float] | None = None,
        self_noise_dba: float | None = None,
        speech_spl_db: float = DEFAULT_SPEECH_SPL_DB,
    ) -> SensorModel:
        """A pair whose rear mic differs from the front by ``gain_db`` and ``phase_deg``.

        ``highpass_hz``: one corner for both mics or ``(front, rear)``; None = no high-pass.
        These are the sweep keys ``mic_gain_db``, ``mic_phase_deg``, ``mic_highpass_hz``,
        ``self_noise_dba`` and ``speech_spl_db``.

        >>> SensorModel.from_mismatch(gain_db=1.0).rear_re_front_gain_db
        1.0
        """
        front_hp, rear_hp = _two_corners(highpass_hz)
        return cls(
            mics=(
                MicResponse(highpass_hz=front_hp),
                MicResponse(gain_db=gain_db, phase_deg=phase_deg, highpass_hz=rear_hp),
            ),
            self_noise_dba=self_noise_dba,
            speech_spl_db=speech_spl_db,
        )

    @property
    def ideal(self) -> bool:
        """True when the sensors are perfect: identity responses and no self-noise."""
        return self.self_noise_dba is None and all(m.ideal for m in self.mics)

    @property
    def linear_ideal(self) -> bool:
        """True when every mic's response is the identity (self-noise aside)."""
        return all(m.ideal for m in self.mics)

    @property
    def rear_re_front_gain_db(self) -> float:
        return self.mics[1].gain_db - self.mics[0].gain_db

    @property
    def rear_re_front_phase_deg(self) -> float:
        return self.mics[1].phase_deg - self.mics[0].phase_deg

    def apply(self, x, *, fs: int) -> np.ndarray:
        """Each channel of ``x`` ``(n_mics, n)`` through its mic's linear response (new array).

        Linear and time-invariant: ``apply(a + b) == apply(a) + apply(b)`` to rounding.
        """
        arr = np.asarray(x, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[0] != len(self.mics):
            raise ParameterError("x", arr, f"a ({len(self.mics)}, n) array, one row per mic")
        if self.linear_ideal:
            return arr.copy()
        return np.stack([m.apply(row[None, :], fs=fs)[0] for m, row in zip(self.mics, arr)])

    def self_noise(self, n_samples: int, *, speech_power: float, fs: int, rng: np.random.Generator) -> np.ndarray:
        """White self-noise ``(n_mics, n_samples)``, independent per mic, at ``self_noise_dba``.

        ``speech_power`` is the digital power of the speech at the reference mic, which
        stands for ``speech_spl_db``.  Zeros when the model has no self-noise.
        """
        if self.self_noise_dba is None:
            return np.zeros((len(self.mics), int(n_samples)))
        if not isinstance(rng, np.random.Generator):
            raise ParameterError("rng", rng, "a numpy.random.Generator")
        var = self_noise_variance(
            self.self_noise_dba, speech_spl_db=self.speech_spl_db, speech_power=speech_power, fs=fs
        )
        return math.sqrt(var) * rng.standard_normal((len(self.mics), int(n_samples)))

    def describe(self) -> dict[str, float | None]:
        """Flat record of the model for a results row (rear re front, per-mic corners)."""
        return {
            "mic_gain_db": self.rear_re_front_gain_db,
            "mic_phase_deg": self.rear_re_front_phase_deg,
            "mic_front_gain_db": self.mics[0].gain_db,
            "mic_rear_gain_db": self.mics[1].gain_db,
            "mic_front_highpass_hz": self.mics[0].highpass_hz,
            "mic_rear_highpass_hz": self.mics[1].highpass_hz,
            "self_noise_dba": self.self_noise_dba,
            "speech_spl_db": self.speech_spl_db,
        }


@dataclass(frozen=True)
class SensorTolerance:
    """Production spread of a phone's mic pair, drawn per seed around nominal values.

    Each mic's sensitivity is drawn uniformly in ``nominal +- gain_tol_db``, the rear mic's
    phase offset in ``nominal +- phase_tol_deg``, each high-pass corner in
    ``nominal +- highpass_tol_hz`` (floored at 1 Hz when a nominal corner exists).
    Sweep keys: ``mic_gain_tol_db``, ``mic_phase_tol_deg``, ``mic_highpass_tol_hz``.

    >>> tol = SensorTolerance(gain_tol_db=1.0)
    >>> m = tol.draw(SensorModel.from_mismatch(), seed=3)
    >>> abs(m.mics[0].gain_db) <= 1.0 and abs(m.mics[1].gain_db) <= 1.0
    True
    """

    gain_tol_db: float = 0.0
    phase_tol_deg: float = 0.0
    highpass_tol_hz: float = 0.0

    def __post_init__(self):
        for name in ("gain_tol_db", "phase_tol_deg", "highpass_tol_hz"):
            object.__setattr__(self, name, check_positive(name, getattr(self, name), allow_zero=True))

    @property
    def none(self) -> bool:
        return self.gain_tol_db == 0.0 and self.phase_tol_deg == 0.0 and self.highpass_tol_hz == 0.0

    def draw(self, nominal: SensorModel, *, seed: int) -> SensorModel:
        """One phone drawn from this spread around ``nominal`` (same seed, same phone)."""
        if self.none:
            return nominal
        rng = np.random.default_rng([int(seed), _TOLERANCE_STREAM])
        # Draw every number even when its tolerance is 0, so one key's tolerance never
        # changes the values another key draws for the same seed.
        gains = rng.uniform(-1.0, 1.0, size=len(nominal.mics)) * self.gain_tol_db
        phase = rng.uniform(-1.0, 1.0) * self.phase_tol_deg
        corners = rng.uniform(-1.0, 1.0, size=len(nominal.mics)) * self.highpass_tol_hz
        mics = []
        for k, m in enumerate(nominal.mics):
            hp = m.highpass_hz
            if hp > 0.0:
                hp = max(1.0, hp + float(corners[k]))
            mics.append(
                MicResponse(
                    gain_db=m.gain_db + float(gains[k]),
                    phase_deg=m.phase_deg + (phase if k == len(nominal.mics) - 1 else 0.0),
                    highpass_hz=hp,
                )
            )
        return SensorModel(tuple(mics), nominal.self_noise_dba, nominal.speech_spl_db)


_TOLERANCE_STREAM = 7  # the rng stream of tolerance draws (apart from the scene's streams)


def mems_self_noise_dba(snr_db: float) -> float:
    """Equivalent input noise in dBA SPL of a MEMS mic with datasheet SNR ``snr_db`` (re 94 dB SPL).

    >>> mems_self_noise_dba(64.0)
    30.0
    """
    return SNR_REFERENCE_SPL_DB - check_finite_number("snr_db", snr_db)
