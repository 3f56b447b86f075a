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
