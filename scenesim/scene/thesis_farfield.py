"""The source thesis' own far-field simulation (its sections 2.5.1 and 6.1), as a selectable model.

The thesis makes each mic's signal from the source signal "by taking the midpoint of the two
microphones as a receiving point", each mic delayed by ``tau_i = -(r_i . u) / c`` about that
midpoint (+-d cos(theta) / (2c): at most half a sample for its 2.14 cm pair at 16 kHz) "by a
fractional delay filter (i.e. sinc interpolator)", and its section 2.5.1 describes that
interpolator as the sinc sampled at ``n - D`` and *truncated* to a finite length.  We read
that as (the equation itself, 2.4, was lost in extraction)::

    h[n] = w[n] sinc(n - D),   n = -M .. M   (L = 2M + 1 taps, centred on the integer grid)

with ``w`` rectangular (plain truncation, ``window="rect"``) or a Hann/Hamming window of the
same L points.  Unlike :mod:`scenesim.scene.fractional_delay` (window centred on the *true* delay,
64 Kaiser taps, error below -90 dB), this filter's error does not vanish: the truncated
tails ``sum_{|n|>M} sinc(n - D) e^{-jwn}`` stay, so two mics delayed by +0.5 and -0.5 sample
are not exact shifted replicas of one plane wave, and a differential null on them is only as
deep as that error allows.  Nothing is delayed in bulk: the mics straddle the source signal
(the midpoint), so the filter is non-causal by M samples and is applied centred.

The angle convention is a second unknown of the thesis (it never defines theta in the
surviving text): ``"axis"`` measures it from the array axis (endfire = 0, Elko's and this
project's convention; 270 deg is broadside), ``"broadside"`` from the broadside direction
towards the front endfire (axis angle = 90 - theta: 45 deg stays 45 deg, 270 deg becomes
rear endfire, 180 deg from the axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from scenesim.errors import ParameterError
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS, MicPair
from scenesim.validate import check_choice, check_finite_number, check_fs, check_int, check_signal

__all__ = ["AZIMUTH_CONVENTIONS", "FD_WINDOWS", "ThesisFarField", "axis_azimuth", "thesis_plane_wave",
           "delay_error_db", "truncated_sinc", "truncation_error"]

AZIMUTH_CONVENTIONS = ("axis", "broadside")
"""How the thesis' angles are read: from the array axis, or from broadside (see the module docstring)."""
FD_WINDOWS = ("rect", "hann", "hamming")
"""Windows of the truncated sinc: plain truncation, or a Hann/Hamming of the same length."""


@dataclass(frozen=True)
class ThesisFarField:
    """The thesis' far-field model: truncated-sinc fractional delays about the array midpoint.

    Parameters
    ----------
    fd_taps : int
        Filter length L (odd, 1..1025): ``2M + 1`` taps centred on the integer grid.
    fd_window : {"rect", "hann", "hamming"}
        Window of the L taps ("rect" = plain truncation, the thesis' text).
    azimuth_from : {"axis", "broadside"}
        Angle convention of the scene's azimuths (:func:`axis_azimuth`).
    """

    fd_taps: int = 33
    fd_window: str = "rect"
    azimuth_from: str = "axis"

    def __post_init__(self):
        taps = check_int("fd_taps", self.fd_taps, minimum=1, maximum=1025)
        if taps % 2 == 0:
            raise ParameterError("fd_taps", taps, "an odd number of taps (2M + 1, centred)")
        check_choice("fd_window", self.fd_window, FD_WINDOWS)
        check_choice("azimuth_from", self.azimuth_from, AZIMUTH_CONVENTIONS)


def axis_azimuth(azimuth_deg: float, convention: str) -> float:
    """The azimuth from the array axis (degrees) of an angle given in ``convention``.

    >>> axis_azimuth(270.0, "broadside"), axis_azimuth(45.0, "broadside"), axis_azimuth(270.0, "axis")
    (180.0, 45.0, 270.0)
    """
    az = check_finite_number("azimuth_deg", azimuth_deg)
    if check_choice("convention", convention, AZIMUTH_CONVENTIONS) == "axis":
        return az
    return float((90.0 - az) % 360.0)


def truncated_sinc(delay_samples: float, *, n_taps: int, window: str = "rect") -> np.ndarray:
    """Taps ``h[n] = w[n] sinc(n - D)``, ``n = -M .. M`` (``n_taps = 2M + 1``), index 0 at ``n = -M``.

    >>> bool(np.allclose(truncated_sinc(0.0, n_taps=5), [0, 0, 1, 0, 0]))
    True
    """
    model = ThesisFarField(fd_taps=n_taps, fd_window=window)
    d = check_finite_number("delay_samples", delay_samples)
    m = model.fd_taps // 2
    n = np.arange(-m, m + 1)
    if window == "rect" or model.fd_taps == 1:
        w = np.ones(n.size)
    else:
        w = np.hanning(n.size + 2)[1:-1] if window == "hann" else np.hamming(n.size)
    return w * np.sinc(n - d)


def truncation_error(delay_samples: float, omega, *, n_taps: int, window: str = "rect") -> np.ndarray:
    """``H(w) - e^{-jwD}`` of :func:`truncated_sinc` at ``omega`` (rad/sample): the filter's complex error.

    For ``window="rect"`` this is minus the truncated tails, ``-sum_{|n|>M} sinc(n - D) e^{-jwn}``.
    """
    h = truncated_sinc(delay_samples, n_taps=n_taps, window=window)
    m = h.size // 2
    w = np.asarray(omega, dtype=float)
    resp = np.exp(-1j * np.outer(w, np.arange(-m, m + 1))) @ h
    return resp - np.exp(-1j * w * float(delay_samples))


def thesis_plane_wave(signal, pair: MicPair, *, azimuth_deg: float, fs: int, model: ThesisFarField,
                      c: float = SPEED_OF_SOUND_MPS) -> np.ndarray:
    """Far-field image ``(2, n)`` of a mono ``signal`` by the thesis' model (no bulk delay).

    Mic i gets ``h_i * signal`` with ``h_i = truncated_sinc(D_i)``, ``D_i = -fs (r_i . u) / c``
    (``r_i`` re the pair centre, ``u`` towards the source at ``axis_azimuth(azimuth_deg)``),
    convolved centred (sample k of the output is aligned with sample k of ``signal``).

    >>> x = np.sin(np.arange(400) * 0.3)
    >>> y = thesis_plane_wave(x, MicPair(), azimuth_deg=90.0, fs=16000, model=ThesisFarField())
    >>> bool(np.array_equal(y[0], y[1]))
    True
    """
    s = np.asarray(signal, dtype=float)
    if s.ndim != 1:
        raise ParameterError("signal", s, "a mono signal shaped (n_samples,)")
    check_signal(s[None, :], name="signal")
    fs = check_fs(fs)
    az = axis_azimuth(azimuth_deg, model.azimuth_from)
    u = pair.direction(az, 0.0)
    r = pair.positions_m - np.asarray(pair.center_m)
    delays = -fs * (r @ u) / float(c)
    m = model.fd_taps // 2
    out = np.empty((2, s.size))
    for i, d in enumerate(delays):
        h = truncated_sinc(float(d), n_taps=model.fd_taps, window=model.fd_window)
        out[i] = sps.oaconvolve(s, h, mode="full")[m:m + s.size]
    return out


def delay_error_db(delay_samples: float, freq_hz: float, *, fs: int, n_taps: int, window: str = "rect") -> float:
    """``20 log10 |H(w) - e^{-jwD}|`` at one frequency: the error a sinusoid delayed by the filter shows.

    >>> round(delay_error_db(0.5, 1000.0, fs=16000, n_taps=33), 1)
    -48.0
    """
    err = truncation_error(delay_samples, [2 * math.pi * freq_hz / fs], n_taps=n_taps, window=window)
    return float(20 * np.log10(max(abs(err[0]), 1e-300)))
