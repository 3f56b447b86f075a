"""Octave bands: a complementary zero-phase filter bank and per-octave decay measurement.

Bands are named by their nominal centre frequencies ``f_b`` (default
:data:`OCTAVE_CENTERS_HZ`, 125 Hz..8 kHz as pyroomacoustics).  The filter bank's magnitude
responses ``W_b(f)`` are real, non-negative and **sum to 1 at every frequency**, so the bands of
a signal add back to the signal exactly (the bank sums to a delta).  Between two neighbouring
centres the weight crosses over as a raised cosine in log-frequency centred on their geometric
mean, over :data:`TRANSITION_OCTAVES` octaves::

    s = clip((log2(f / sqrt(f_b f_{b+1})) / TRANSITION_OCTAVES) + 1/2, 0, 1)
    W_b += cos^2(pi s / 2) on the crossover,  W_{b+1} = sin^2(pi s / 2)

The lowest band extends to DC and the highest to Nyquist.  Filtering is done by FFT with
zero padding (zero phase, non-causal: a band's ringing before t = 0 is cut off, and the cut
parts of all bands cancel when the bands carry the same signal).

Per-octave reverberation time (:func:`octave_rt60`) uses the usual analysis filters instead:
a 3rd-order Butterworth band-pass ``[f_b / sqrt 2, f_b sqrt 2]`` run forward and backward
(zero phase, so the filter's own decay does not lengthen the measured one), then
:func:`scenesim.room.rt60.measure_rt60` on each band.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import fft as sfft
from scipy import signal

from scenesim.errors import ParameterError
from scenesim.room.rt60 import measure_rt60
from scenesim.validate import check_fs

OCTAVE_CENTERS_HZ = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)
"""Nominal octave-band centres (Hz), as pyroomacoustics' default materials."""
SPEECH_BANDS_HZ = (500.0, 1000.0, 2000.0)
"""Octaves whose mean T30 is "the decay speech hears" (ISO 3382's T_mid is 500 Hz and 1 kHz;
2 kHz is added because it carries most of speech intelligibility)."""
TRANSITION_OCTAVES = 0.5
"""Width of each crossover of the complementary filter bank, in octaves (flat +-1/4 octave
around every centre)."""


def check_centers(centers_hz) -> tuple[float, ...]:
    """Return band centres as a tuple of floats, or raise: strictly increasing, > 0, finite."""
    c = np.asarray(centers_hz, dtype=float) if not isinstance(centers_hz, str) else None
    if c is None or c.ndim != 1 or c.size < 1 or not np.all(np.isfinite(c)) or np.any(c <= 0) \
            or np.any(np.diff(c) <= 0):
        raise ParameterError("bands_hz", centers_hz, "strictly increasing centre frequencies > 0 Hz")
    return tuple(float(v) for v in c)


def exact_midband_hz(centers_hz) -> np.ndarray:
    """Exact octave midband frequencies ``1000 * 10^(3k/10)`` nearest to nominal centres (ISO 266)."""
    c = np.asarray(check_centers(centers_hz))
    k = np.round(10.0 * np.log10(c / 1000.0) / 3.0)
    exact = 1000.0 * 10.0 ** (3.0 * k / 10.0)
    # Non-octave centres (not within 3 % of an exact octave) are kept as given.
    return np.where(np.abs(exact / c - 1.0) < 0.03, exact, c)


def band_weights(freqs_hz, centers_hz, *, transition_octaves: float = TRANSITION_OCTAVES) -> np.ndarray:
    """Complementary magnitude responses ``(n_bands, n_freqs)``; columns sum to exactly 1.

    Example: ``band_weights(np.fft.rfftfreq(512, 1 / 16000), OCTAVE_CENTERS_HZ).sum(0)`` is all ones.
    """
    centers = np.asarray(check_centers(centers_hz))
    if not 0.0 < transition_octaves <= 1.0:
        raise ParameterError("transition_octaves", transition_octaves, "a width in (0, 1] octaves")
    f = np.asarray(freqs_hz, dtype=float)
    n = centers.size
    # upper[b] = share of band b above crossover b (between b and b+1); the rest goes up.
    w = np.zeros((n, f.size))
    remaining = np.ones(f.size)
    with np.errstate(divide="ignore"):
        logf = np.log2(np.maximum(f, 1e-12))
    for b in range(n - 1):
        cross = 0.5 * (math.log2(centers[b]) + math.log2(centers[b + 1]))
        s = np.clip((logf - cross) / transition_octaves + 0.5, 0.0, 1.0)
        low_share = np.cos(0.5 * np.pi * s) ** 2
        w[b] = remaining * low_share
        remaining = remaining - w[b]
    w[n - 1] = remaining
    return w


def split_bands(x, fs, centers_hz, *, transition_octaves: float = TRANSITION_OCTAVES) -> np.ndarray:
    """Split ``x`` ``(..., n)`` into bands ``(n_bands, ..., n)`` that sum back to ``x`` exactly.

    Zero-phase FFT filtering with :func:`band_weights`; the buffer is padded by at least a
    quarter second so the bands' ringing does not wrap onto the kept taps.

    Example: ``np.allclose(split_bands(h, 16000, OCTAVE_CENTERS_HZ).sum(0), h)`` is True.
    """
    fs = check_fs(fs)
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    n_fft = sfft.next_fast_len(n + 2 * max(fs // 4, 256), real=True)
    spec = sfft.rfft(x, n_fft, axis=-1)
    w = band_weights(sfft.rfftfreq(n_fft, 1.0 / fs), centers_hz, transition_octaves=transition_octaves)
    out = sfft.irfft(w.reshape((w.shape[0],) + (1,) * (x.ndim - 1) + (w.shape[1],)) * spec, n_fft, axis=-1)
    return out[..., :n]


def combine_bands(band_signals, fs, centers_hz, *, transition_octaves: float = TRANSITION_OCTAVES) -> np.ndarray:
    """``sum_b W_b * x_b``: band ``b`` of its own signal ``x_b`` (``(n_bands, ..., n)`` -> ``(..., n)``).

    With identical ``x_b`` this returns ``x_b`` (the bank is complementary).  Used to build a
    frequency-dependent RIR from per-band RIRs rendered with each band's wall reflection.
    """
    fs = check_fs(fs)
    xb = np.asarray(band_signals, dtype=float)
    centers = check_centers(centers_hz)
    if xb.shape[0] != len(centers):
        raise ParameterError("band_signals", xb.shape, f"{len(centers)} bands on the first axis")
    n = xb.shape[-1]
    n_fft = sfft.next_fast_len(n + 2 * max(fs // 4, 256), real=True)
    w = band_weights(sfft.rfftfreq(n_fft, 1.0 / fs), centers, transition_octaves=transition_octaves)
    acc = None
    for b in range(xb.shape[0]):
        if not np.any(w[b]):
            continue  # a band entirely above Nyquist
        part = sfft.rfft(xb[b], n_fft, axis=-1) * w[b]
        acc = part if acc is None else acc + part
    return sfft.irfft(acc, n_fft, axis=-1)[..., :n]


def active_bands(centers_hz, fs) -> np.ndarray:
    """Boolean mask ``(n_bands,)``: bands whose weight is non-zero somewhere below Nyquist."""
    fs = check_fs(fs)
    w = band_weights(np.linspace(0.0, fs / 2.0, 4097), centers_hz)
    return np.any(w > 0, axis=1)


def octave_filter(h, fs, center_hz: float) -> np.ndarray:
    """``h`` through a zero-phase 3rd-order Butterworth octave band-pass at ``center_hz``."""
    fs = check_fs(fs)
    hi = min(center_hz * math.sqrt(2.0), 0.499 * fs)
    lo = center_hz / math.sqrt(2.0)
    if lo >= hi:
        raise ParameterError("center_hz", center_hz, f"an octave below Nyquist ({fs / 2:g} Hz)")
    sos = signal.butter(3, [lo, hi], btype="bandpass", fs=fs, output="sos")
    return signal.sosfiltfilt(sos, np.asarray(h, dtype=float), axis=-1)


def octave_rt60(h, fs, centers_hz=OCTAVE_CENTERS_HZ, *, method: str = "T30") -> np.ndarray:
    """Per-octave reverberation time ``(n_bands,)`` (or ``(n_channels, n_bands)``) in seconds.

    ``h`` is ``(n,)`` or ``(n_channels, n)``; each octave is measured by
    :func:`scenesim.room.rt60.measure_rt60` on :func:`octave_filter`'s output.

    Example: ``octave_rt60(h, 16000, (500, 1000, 2000))``.
    """
    centers = check_centers(centers_hz)
    out = [np.atleast_1d(measure_rt60(octave_filter(h, fs, fc), fs, method=method)) for fc in centers]
    res = np.stack(out, axis=-1)
    return res[0] if np.ndim(h) == 1 else res


def speech_rt60(h, fs, *, method: str = "T30") -> float | np.ndarray:
    """Mean of the :data:`SPEECH_BANDS_HZ` octave T30s: the decay speech hears (s)."""
    return np.mean(octave_rt60(h, fs, SPEECH_BANDS_HZ, method=method), axis=-1)


__all__ = [
    "OCTAVE_CENTERS_HZ",
    "SPEECH_BANDS_HZ",
    "TRANSITION_OCTAVES",
    "active_bands",
    "band_weights",
    "check_centers",
    "combine_bands",
    "exact_midband_hz",
    "octave_filter",
    "octave_rt60",
    "speech_rt60",
    "split_bands",
]
