"""Air absorption of sound (ISO 9613-1:1993, section 6) and its time-varying gain on an RIR.

Pure-tone attenuation coefficient in dB/m (``f`` Hz, ``T`` K, ``h`` molar concentration of
water vapour in %, ``pa`` ambient pressure, ``pr`` = 101.325 kPa, ``T0`` = 293.15 K,
``T01`` = 273.16 K)::

    a = 8.686 f^2 [ 1.84e-11 (pa/pr)^-1 (T/T0)^(1/2)
                    + (T/T0)^(-5/2) ( 0.01275 exp(-2239.1/T) / (frO + f^2/frO)
                                    + 0.1068  exp(-3352.0/T) / (frN + f^2/frN) ) ]
    frO = (pa/pr) (24 + 4.04e4 h (0.02 + h) / (0.391 + h))                 (oxygen relaxation)
    frN = (pa/pr) (T/T0)^(-1/2) (9 + 280 h exp(-4.170 ((T/T0)^(-1/3) - 1)))   (nitrogen)
    h = h_r (psat/pr) / (pa/pr),  psat/pr = 10^(-6.8346 (T01/T)^1.261 + 4.6151)

An image arriving at time ``t`` has travelled ``r = c t``, so its amplitude is multiplied by
``10^(-a r / 20)``.  Applied per octave band as the time-dependent gain
``10^(-a_b c t / 20)`` on that band's RIR it is exact for every image up to the spread of
its band-limited kernel (a few samples, i.e. a few centimetres of path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scenesim.errors import ParameterError
from scenesim.validate import check_fs, check_positive, check_range

_PR_KPA = 101.325
_T0_K = 293.15
_T01_K = 273.16
_DB_PER_NEPER = 20.0 / math.log(10.0)  # 8.686: amplitude nepers -> dB


def attenuation_db_per_m(frequency_hz, *, temperature_c: float = 20.0, humidity_pct: float = 50.0,
                         pressure_kpa: float = _PR_KPA) -> np.ndarray:
    """ISO 9613-1 pure-tone attenuation coefficient in dB/m (equation 5 of the standard).

    Parameters
    ----------
    frequency_hz : float or array
        Frequencies in Hz (> 0).
    temperature_c : float
        Air temperature in degrees Celsius (-20..50 is the standard's tabulated range).
    humidity_pct : float
        Relative humidity in percent, 0..100.
    pressure_kpa : float
        Ambient pressure in kPa.

    Returns
    -------
    ndarray shaped like ``frequency_hz`` (float for a scalar input).

    Examples
    --------
    >>> round(float(attenuation_db_per_m(1000.0, temperature_c=20.0, humidity_pct=70.0)) * 1000, 1)  # dB/km
    5.0
    """
    f = np.asarray(frequency_hz, dtype=float)
    if not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ParameterError("frequency_hz", frequency_hz, "finite frequencies > 0 Hz")
    t_k = check_range("temperature_c", temperature_c, -60.0, 60.0) + 273.15
    hr = check_range("humidity_pct", humidity_pct, 0.0, 100.0)
    p = check_positive("pressure_kpa", pressure_kpa) / _PR_KPA
    psat = 10.0 ** (-6.8346 * (_T01_K / t_k) ** 1.261 + 4.6151)
    h = hr * psat / p
    tr = t_k / _T0_K
    fr_o = p * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
    fr_n = p / math.sqrt(tr) * (9.0 + 280.0 * h * math.exp(-4.170 * (tr ** (-1.0 / 3.0) - 1.0)))
    a = 8.686 * f**2 * (
        1.84e-11 / p * math.sqrt(tr)
        + tr**-2.5 * (
            0.01275 * math.exp(-2239.1 / t_k) / (fr_o + f**2 / fr_o)
            + 0.1068 * math.exp(-3352.0 / t_k) / (fr_n + f**2 / fr_n)
        )
    )
    return float(a) if a.ndim == 0 else a


@dataclass(frozen=True)
class AirAbsorption:
    """Air conditions for ISO 9613-1 absorption (a value object a :class:`ShoeBox` can carry).

    ``ShoeBox(..., air=AirAbsorption(temperature_c=20, humidity_pct=50))`` makes every RIR of
    that room attenuate each path of length ``r`` by ``10^(-a(f) r / 20)`` per octave band.
    """

    temperature_c: float = 20.0
    humidity_pct: float = 50.0
    pressure_kpa: float = _PR_KPA

    def __post_init__(self):
        object.__setattr__(self, "temperature_c", check_range("temperature_c", self.temperature_c, -60.0, 60.0))
        object.__setattr__(self, "humidity_pct", check_range("humidity_pct", self.humidity_pct, 0.0, 100.0))
        object.__setattr__(self, "pressure_kpa", check_positive("pressure_kpa", self.pressure_kpa))

    def db_per_m(self, frequency_hz) -> np.ndarray:
        """Attenuation coefficient in dB/m at ``frequency_hz`` (:func:`attenuation_db_per_m`)."""
        return attenuation_db_per_m(frequency_hz, temperature_c=self.temperature_c,
                                    humidity_pct=self.humidity_pct, pressure_kpa=self.pressure_kpa)


def air_gain(n_taps: int, fs, db_per_m: float, c: float) -> np.ndarray:
    """Time-dependent amplitude gain ``(n_taps,)``: ``10^(-a c t / 20)`` at ``t = n / fs``.

    Example: ``h_band * air_gain(h_band.shape[-1], 16000, 0.005, 343.0)``.
    """
    fs = check_fs(fs)
    if not math.isfinite(db_per_m) or db_per_m < 0:
        raise ParameterError("db_per_m", db_per_m, "a finite attenuation >= 0 dB/m")
    t = np.arange(int(n_taps)) / fs
    return 10.0 ** (-db_per_m * check_positive("c", c) * t / 20.0)


__all__ = ["AirAbsorption", "air_gain", "attenuation_db_per_m"]
