"""Small validators shared by every layer; each raises :class:`ParameterError` naming the parameter.

Never use ``assert`` for input checks: asserts vanish under ``python -O`` and give no message.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from scenesim.errors import ParameterError


def check_finite_number(name: str, value) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(name, value, "a finite real number")
    value = float(value)
    if not math.isfinite(value):
        raise ParameterError(name, value, "a finite real number")
    return value


def check_positive(name: str, value, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a float if it is finite and > 0 (>= 0 with ``allow_zero``)."""
    value = check_finite_number(name, value)
    if value < 0 or (value == 0 and not allow_zero):
        raise ParameterError(name, value, "a number >= 0" if allow_zero else "a number > 0")
    return value


def check_range(
    name: str, value, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False
) -> float:
    """Return ``value`` as a float if it lies in the interval [lo, hi] (ends optionally open)."""
    value = check_finite_number(name, value)
    too_low = value <= lo if lo_open else value < lo
    too_high = value >= hi if hi_open else value > hi
    if too_low or too_high:
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise ParameterError(name, value, f"a value in {interval}")
    return value


def check_int(name: str, value, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """Return ``value`` as an int if it is integral and within the optional bounds."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(name, value, "an integer")
    value = int(value)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        lo = "-inf" if minimum is None else minimum
        hi = "inf" if maximum is None else maximum
        raise ParameterError(name, value, f"an integer in [{lo}, {hi}]")
    return value


def check_choice(name: str, value, choices: Sequence[str]) -> str:
    """Return ``value`` if it is one of ``choices``."""
    if value not in choices:
        raise ParameterError(name, value, "one of " + ", ".join(repr(c) for c in choices))
    return value


def check_fs(fs, *, supported: Sequence[int] | None = None) -> int:
    """Return the sampling rate as an int (Hz); ``supported`` restricts it to a list."""
    if isinstance(fs, (float, np.floating)) and float(fs).is_integer():
        fs = int(fs)
    fs = check_int("fs", fs, minimum=1)
    if supported is not None and fs not in supported:
        raise ParameterError("fs", fs, "one of " + ", ".join(str(s) for s in supported) + " Hz")
    return fs


def check_audio_fs(fs, *, supported: Sequence[int] | None = None, name: str = "fs") -> int:
    """:func:`check_fs` held to the physical range of ``--fs`` as well (8000-192000 Hz): the rate
    of a signal an enhancer or a metric is given, where 1 Hz or 100 MHz is a mistake, not audio.

    >>> check_audio_fs(16000)
    16000
    >>> check_audio_fs(100_000_000)
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter fs=100000000 is invalid: expected a sampling rate in [8000, 192000] Hz.
    """
    fs = check_fs(fs, supported=supported)
    lo, hi, _, what = PHYSICAL_RANGES["fs"]
    if not lo <= fs <= hi:
        raise ParameterError(name, fs, f"{what} in {physical_range_text('fs')}")
    return fs


def check_signal(
    x, *, name: str = "x", n_channels: int | None = None, min_samples: int = 1
) -> np.ndarray:
    """Validate a multichannel signal and return it as a float64 ``(n_channels, n_samples)`` array.

    The input is never modified; a copy is made only when the dtype must change.
    Raises :class:`ParameterError` for 1-D or >2-D input, a wrong channel count,
    fewer than ``min_samples`` samples, non-numeric data, NaN or Inf.
    """
    arr = np.asarray(x)
    if arr.dtype.kind not in "fiu":
        raise ParameterError(name, arr, "a real-valued numeric array")
    if arr.ndim != 2:
        raise ParameterError(name, arr, "a 2-D array shaped (n_channels, n_samples)")
    if n_channels is not None and arr.shape[0] != n_channels:
        raise ParameterError(name, arr, f"{n_channels} channel(s) on axis 0")
    if arr.shape[1] < min_samples:
        raise ParameterError(name, arr, f"at least {min_samples} sample(s) on axis 1")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "finite values only (no NaN or Inf)")
    return arr


#: Physical ranges of scene quantities, ``quantity -> (lo, hi, unit, why)``: one table read by
#: the sweep parser (``benchmarks.run.sweep``) and the CLI (``simulate``, ``rir``, ``enhance``), so
#: a value refused in one place is refused everywhere with the same range.
PHYSICAL_RANGES: dict[str, tuple[float, float, str, str]] = {
    # 80 dB is beyond the float resolution of a mixture; -50 dB leaves no speech to enhance.
    "snr_db": (-50.0, 80.0, "dB", "an input SNR"),
    # PESQ needs 1/4 s (metrics.PESQ_MIN_S); each second of a condition costs ~50 MB of memory.
    "duration_s": (0.25, 120.0, "s", "a signal length"),
    # Phone pairs are 1-20 cm apart; below 2 mm the mics coincide, above 0.5 m it is no phone.
    "spacing_m": (0.002, 0.5, "m", "a mic spacing"),
    "azimuth_deg": (-360.0, 720.0, "deg", "an azimuth"),
    "distance_m": (0.01, 100.0, "m", "a source distance"),
    "room_dim_m": (0.5, 200.0, "m", "a room length"),
    # The longest-reverberating halls measure ~12 s; past 20 s the ISM runs for hours.
    "rt60_s": (0.0, 20.0, "s", "an RT60 (0 = anechoic)"),
    # SQLite stores integers as signed 64-bit.
    "seed": (0, 2**63 - 1, "", "a seed"),
    # A mic's high-pass corner: above 2 kHz it removes the speech band (phone MEMS: 20-200 Hz).
    "highpass_hz": (0.0, 2000.0, "Hz", "a high-pass corner"),
    # An RIR outlasts its decay: the longest RT60 (20 s) falls 180 dB in 60 s, far below float resolution.
    "rir_length_s": (1e-3, 60.0, "s", "an RIR length"),
    # Speed of sound: -50 to +60 degC air.
    "c_mps": (300.0, 400.0, "m/s", "a speed of sound"),
    # The CLI's lowest rate is the telephone band; above 192 kHz no audio interface records.
    "fs": (8000, 192000, "Hz", "a sampling rate"),
}

#: Band (Hz) holding most speech energy: an SNR band must overlap it by :data:`MIN_SNR_BAND_HZ`.
SPEECH_BAND_HZ = (100.0, 4000.0)
MIN_SNR_BAND_HZ = 100.0


def physical_range_text(quantity: str) -> str:
    """``"[lo, hi] unit"`` of a :data:`PHYSICAL_RANGES` entry.

    >>> physical_range_text("snr_db")
    '[-50, 80] dB'
    """
    lo, hi, unit, _ = PHYSICAL_RANGES[quantity]
    return f"[{lo:g}, {hi:g}]" + (f" {unit}" if unit else "")


def check_physical(name: str, value, quantity: str | None = None) -> float:
    """``value`` as a float if it lies in the physical range of ``quantity`` (default ``name``).

    ``name`` is what the user typed (``"--snr-db"``, ``"snr_db"``) and is named in the error.

    >>> check_physical("--snr-db", 10, "snr_db")
    10.0
    >>> check_physical("--snr-db", 1e300, "snr_db")
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter --snr-db=1e+300 is invalid: expected an input SNR in [-50, 80] dB.
    """
    quantity = quantity or name
    lo, hi, _, what = PHYSICAL_RANGES[quantity]
    value = check_finite_number(name, value)
    if not lo <= value <= hi:
        raise ParameterError(name, value, f"{what} in {physical_range_text(quantity)}")
    return value


def check_seed(name: str, value) -> int:
    """``value`` as an int if it is an integer in the range SQLite can store (>= 0).

    >>> check_seed("seed", 2**63)
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter seed=9223372036854775808 is invalid: expected an integer in [0, 9223372036854775807].
    """
    lo, hi, _, _ = PHYSICAL_RANGES["seed"]
    return check_int(name, value, minimum=lo, maximum=hi)


def check_snr_band(name: str, band, fs: float) -> tuple[float, float]:
    """``(lo, hi)`` Hz if ``0 <= lo < hi <= fs/2`` and it overlaps :data:`SPEECH_BAND_HZ` by
    at least :data:`MIN_SNR_BAND_HZ` (a band without speech has no speech power to set an SNR).

    >>> check_snr_band("snr_band_hz", (300, 3400), 16000)
    (300.0, 3400.0)
    >>> check_snr_band("snr_band_hz", (6000, 7000), 16000)
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter snr_band_hz=(6000, 7000) is invalid: expected a band overlapping the speech band 100-4000 Hz by >= 100 Hz.
    """
    lo, hi = (check_finite_number(name, v) for v in band)
    if not 0 <= lo < hi <= fs / 2:
        raise ParameterError(name, band, f"[lo, hi] with 0 <= lo < hi, hi not above fs/2 = {fs / 2:g} Hz")
    s_lo, s_hi = SPEECH_BAND_HZ
    if min(hi, s_hi) - max(lo, s_lo) < MIN_SNR_BAND_HZ:
        raise ParameterError(
            name, band, f"a band overlapping the speech band {s_lo:g}-{s_hi:g} Hz by >= {MIN_SNR_BAND_HZ:g} Hz"
        )
    return lo, hi


def check_outside_pair(name: str, distance_m: float, spacing_m: float) -> float:
    """``distance_m`` if a source that far from the pair centre lies outside the pair: at least
    one ``spacing_m`` away (closer, it sits between or on the mics and the far-field and
    point-source models mean nothing).

    >>> check_outside_pair("distance_m", 0.01, 0.0214)
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter distance_m=0.01 is invalid: expected a distance >= the mic spacing 0.0214 m (the source would sit between or on the mics).
    """
    if distance_m < spacing_m:
        raise ParameterError(
            name, distance_m,
            f"a distance >= the mic spacing {spacing_m:g} m (the source would sit between or on the mics)",
        )
    return distance_m
