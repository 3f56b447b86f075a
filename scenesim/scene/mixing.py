"""Signal power, active speech level and mixing at a target SNR (algorithms.md section 4).

Thesis eq. 7.1: the noise is scaled so that ``10 log10(P_speech / P_noise) = SNR`` at the
reference mic.  ``P`` is the mean square over the whole signal (``mode="total"``, the
thesis) or, for the speech, its *active* level (``mode="active"``, ITU-T P.56 style); the
noise power is always the mean square over the whole signal.

Active speech level (simplified ITU-T P.56, method B).  Implemented:

* envelope ``q``: two cascaded first-order smoothers of ``|x|`` with a 0.03 s time constant;
* hangover 0.2 s: a sample counts as active for threshold ``c`` if ``q >= c`` anywhere in the
  last 0.2 s (running maximum, equivalent to P.56's hangover counter);
* for each threshold ``c``: ``A(c) = 10 log10(sum x^2 / n_active(c))``, ``C = 20 log10 c``;
  the active level is ``A`` where ``A - C`` falls to the margin ``M = 15.9 dB`` (first crossing
  from low thresholds), linearly interpolated between neighbouring thresholds.

Not implemented / different from P.56: thresholds on a 0.25 dB grid spanning 120 dB below
the envelope peak instead of P.56's 2^j (6 dB) steps on integer sample values (a finer
grid, so the interpolation error is smaller); no band-limiting or DC removal of the input;
when no crossing exists (e.g. a constant-envelope signal whose ``A - C`` never reaches M
from above) the whole-signal power is returned; silence returns 0.
"""

from __future__ import annotations

import numpy as np
from scipy import signal as sps
from scipy.ndimage import maximum_filter1d

from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_finite_number, check_fs, check_signal

P56_TIME_CONSTANT_S = 0.03
P56_HANGOVER_S = 0.2
P56_MARGIN_DB = 15.9
_GRID_STEP_DB = 0.25
_GRID_SPAN_DB = 120.0
_MODES = ("total", "active")


def _as_2d(x, name: str) -> np.ndarray:
    arr = np.asarray(x)
    if arr.ndim == 1:
        arr = arr[None, :]
    return check_signal(arr, name=name)


def signal_power(x) -> float:
    """Mean square of ``x`` ((n,) or (n_ch, n)) over all its samples (and channels)."""
    return float(np.mean(np.square(_as_2d(x, "x"))))


def active_speech_power(x, fs: int) -> float:
    """Active speech power (mean square while active) of a mono signal, simplified P.56.

    Parameters
    ----------
    x : array (n,) or (1, n)
        Speech, in any units (the level is relative to them).
    fs : int
        Sampling rate in Hz.

    Returns
    -------
    float
        Power (not dB).  ``10 log10`` of it is the active speech level; 0.0 for silence.
    """
    arr = _as_2d(x, "x")
    if arr.shape[0] != 1:
        raise ParameterError("x", arr, "a mono signal")
    x1 = arr[0]
    fs = check_fs(fs)
    energy = float(np.sum(x1 * x1))
    if energy == 0.0:
        return 0.0
    _, q_hold = _p56_envelope(x1, fs)
    peak = float(q_hold.max())
    if peak <= 0.0:
        return energy / x1.size
    c_db = np.arange(20.0 * np.log10(peak) - _GRID_SPAN_DB, 20.0 * np.log10(peak), _GRID_STEP_DB)
    sorted_q = np.sort(q_hold)
    n_active = x1.size - np.searchsorted(sorted_q, 10.0 ** (c_db / 20.0), side="left")
    keep = n_active > 0
    c_db, n_active = c_db[keep], n_active[keep]
    a_db = 10.0 * np.log10(energy / n_active)
    delta = a_db - c_db  # decreases as the threshold rises
    below = np.flatnonzero(delta <= P56_MARGIN_DB)
    if below.size == 0 or below[0] == 0:
        return energy / x1.size
    j = below[0]
    # Linear interpolation of A between thresholds j-1 and j at delta = M.
    w = (delta[j - 1] - P56_MARGIN_DB) / (delta[j - 1] - delta[j])
    level_db = a_db[j - 1] + w * (a_db[j] - a_db[j - 1])
    return float(10.0 ** (level_db / 10.0))


def _p56_envelope(x1: np.ndarray, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """P.56's envelope ``q`` of a 1-D signal and ``q`` held over the hangover (running maximum)."""
    g = np.exp(-1.0 / (fs * P56_TIME_CONSTANT_S))
    # Two cascaded one-pole smoothers: p = g p + (1-g)|x|, q = g q + (1-g) p.
    q = sps.lfilter([(1.0 - g) ** 2], [1.0, -2.0 * g, g * g], np.abs(x1))
    width = int(round(P56_HANGOVER_S * fs)) + 1
    return q, maximum_filter1d(q, size=width, origin=(width - 1) // 2, mode="constant", cval=0.0)


def p56_activity(x, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample speech activity of a mono signal by P.56 method B (see the module docstring).

    The threshold is the one the active level was found at, ``C = A - M`` (dB, amplitude
    ``10^(C/20)``).  Returns ``(active, held)``, boolean arrays of shape ``(n,)``: ``active``
    where the envelope is at or above it, ``held`` where it was so within the last
    :data:`P56_HANGOVER_S` s (P.56's activity, hangover included).  Silence: nothing active.

    >>> fs = 8000
    >>> x = np.concatenate([np.sin(2 * np.pi * 500 * np.arange(fs) / fs), np.zeros(fs)])
    >>> active, held = p56_activity(x, fs)
    >>> round(float(active.sum()) / fs, 2), round(float(held.sum() - active.sum()) / fs, 2)
    (1.08, 0.2)

    The 1 s tone is active 1.08 s: its envelope (two 30 ms smoothers, step response
    ``1 - (1 + t/τ) e^(-t/τ)``) crosses the threshold, 0.178 of its final value (−15.9 dB
    re the tone's active level), 18 ms after the onset and decays below it 95 ms after the
    end; the hangover adds 0.2 s.
    """
    arr = _as_2d(x, "x")
    if arr.shape[0] != 1:
        raise ParameterError("x", arr, "a mono signal")
    level = active_speech_power(arr, fs)
    q, q_hold = _p56_envelope(arr[0], check_fs(fs))
    if level <= 0.0:
        return np.zeros(q.size, dtype=bool), np.zeros(q.size, dtype=bool)
    c = 10.0 ** ((10.0 * np.log10(level) - P56_MARGIN_DB) / 20.0)
    return q >= c, q_hold >= c


def noise_gain_for_snr(
    speech_ref, noise_ref, snr_db: float, *, mode: str = "total", fs: int | None = None
) -> float:
    """Amplitude gain ``g`` for the noise so that ``10 log10(P_s / (g^2 P_n)) = snr_db``.

    Parameters
    ----------
    speech_ref, noise_ref : array (n,) or (1, n)
        Speech and noise at the reference mic (thesis eq. 7.1).
    snr_db : float
        Target SNR in dB.
    mode : {"total", "active"}
        Speech power over the whole signal, or its P.56-style active level (needs ``fs``).
    fs : int, optional
        Sampling rate (required for ``mode="active"``).
    """
    mode = check_choice("mode", mode, _MODES)
    snr_db = check_finite_number("snr_db", snr_db)
    if mode == "active":
        if fs is None:
            raise ParameterError("fs", fs, "a sampling rate in Hz when mode='active'")
        p_s = active_speech_power(_as_2d(speech_ref, "speech_ref"), fs)
    else:
        p_s = signal_power(_as_2d(speech_ref, "speech_ref"))
    p_n = signal_power(_as_2d(noise_ref, "noise_ref"))
    if p_s <= 0.0:
        raise ParameterError("speech_ref", speech_ref, "a signal with non-zero power")
    if p_n <= 0.0:
        raise ParameterError("noise_ref", noise_ref, "a signal with non-zero power")
    return noise_gain_from_powers(p_s, p_n, snr_db)


def noise_gain_from_powers(speech_power: float, noise_power: float, snr_db: float) -> float:
    """Thesis eq. 7.1 solved for the noise amplitude gain: ``g = sqrt(P_s / (P_n 10^(snr_db/10)))``.

    The one place the formula is written (:func:`noise_gain_for_snr` and
    ``SceneImages.mix`` call it).  Powers are mean squares, > 0.

    >>> noise_gain_from_powers(1.0, 4.0, 0.0)
    0.5
    """
    return float(np.sqrt(speech_power / (noise_power * 10.0 ** (snr_db / 10.0))))


def mix_at_snr(
    speech,
    noise,
    snr_db: float,
    *,
    mode: str = "total",
    fs: int | None = None,
    ref_channel: int = 0,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Scale ``noise`` to ``snr_db`` at ``ref_channel`` and add it to ``speech``.

    Parameters
    ----------
    speech, noise : array (n_ch, n) or (n,)
        Speech and noise images, same shape; not modified.
    snr_db, mode, fs
        See :func:`noise_gain_for_snr`.
    ref_channel : int
        Channel whose SNR is set (0 = front/reference mic).

    Returns
    -------
    mixture : ndarray, shape of ``speech``
    scaled_noise : ndarray, shape of ``noise``
    gain : float
        The amplitude gain applied to ``noise``.
    """
    s = _as_2d(speech, "speech")
    n = _as_2d(noise, "noise")
    if s.shape != n.shape:
        raise ParameterError("noise", n, f"the shape of speech {s.shape}")
    if not 0 <= int(ref_channel) < s.shape[0]:
        raise ParameterError(
            "ref_channel", ref_channel, f"a channel index in [0, {s.shape[0] - 1}]"
        )
    g = noise_gain_for_snr(s[ref_channel], n[ref_channel], snr_db, mode=mode, fs=fs)
    scaled = g * n
    mixture = s + scaled
    if np.ndim(speech) == 1:
        return mixture[0], scaled[0], g
    return mixture, scaled, g


def check_band(band_hz, *, fs: int, name: str = "snr_band_hz") -> tuple[float, float]:
    """``(lo, hi)`` in Hz with ``0 <= lo < hi <= fs/2``, as floats."""
    try:
        lo, hi = (float(v) for v in band_hz)
    except (TypeError, ValueError):
        raise ParameterError(name, band_hz, "two frequencies [lo, hi] in Hz") from None
    nyquist = check_fs(fs) / 2.0
    if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 <= lo < hi <= nyquist):
        raise ParameterError(name, band_hz, f"[lo, hi] with 0 <= lo < hi <= fs/2 = {nyquist:g} Hz")
    return lo, hi


def bandlimit(x, fs: int, band_hz) -> np.ndarray:
    """``x`` ((n,) or (n_ch, n)) with every frequency outside ``band_hz`` removed (a new array).

    An ideal (brick-wall, zero-phase) filter on the full-length FFT: the measurement filter
    of an in-band SNR, where only the powers matter.

    >>> t = np.arange(16000) / 16000
    >>> y = bandlimit(np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 1000 * t), 16000, (100, 7000))
    >>> round(float(np.mean(y ** 2)), 3)
    0.5
    """
    lo, hi = check_band(band_hz, fs=fs)
    arr = np.asarray(x, dtype=np.float64)
    n = arr.shape[-1]
    spec = np.fft.rfft(arr, axis=-1)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    spec[..., (f < lo) | (f > hi)] = 0.0
    return np.fft.irfft(spec, n=n, axis=-1)
