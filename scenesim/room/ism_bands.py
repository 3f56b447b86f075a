"""Octave-band split/merge for per-band image-source rendering.

A per-band quantity (directivity, wall absorption) gives one RIR per band, rendered with that
band's gains; the broadband RIR is ``sum_b W_b * h_b`` with zero-phase band weights
``W_b(f)`` that sum to exactly 1 at every frequency (a partition of unity), so equal gains in
every band reproduce the single-band RIR to rounding.

Weights: band edges at the geometric means of adjacent centres; across each edge the lower
band falls as ``cos^2`` and the upper rises as ``sin^2`` of ``pi/2 x``, x going 0 -> 1 over
``TRANSITION_OCTAVES`` centred on the edge in log2 frequency.  The first band reaches down to
DC, the last up to Nyquist.  Applied by FFT with zero padding (no circular wrap inside the
returned taps); being zero-phase, a band filter rings a few ms before an arrival too
(the lowest edge, 177 Hz with a half-octave transition, gives ~10 ms of ringing).
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from scenesim.errors import ParameterError

OCTAVE_CENTRES_HZ = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)
"""Default octave-band centre frequencies (Hz)."""
TRANSITION_OCTAVES = 0.5
"""Width of each crossover, in octaves, centred on the edge between two bands."""


def check_bands(bands_hz) -> np.ndarray:
    """Validate strictly increasing positive centre frequencies; returns a float array."""
    b = np.asarray(bands_hz, dtype=float) if not isinstance(bands_hz, str) else None
    if b is None or b.ndim != 1 or b.size == 0 or not np.all(np.isfinite(b)) or np.any(b <= 0) \
            or np.any(np.diff(b) <= 0):
        raise ParameterError("bands_hz", bands_hz, "strictly increasing centre frequencies > 0 in Hz")
    return b


def band_weights(freqs_hz: np.ndarray, bands_hz) -> np.ndarray:
    """Zero-phase weights ``(n_bands, n_freqs)`` at ``freqs_hz``; each column sums to 1."""
    centres = check_bands(bands_hz)
    f = np.asarray(freqs_hz, dtype=float)
    n = centres.size
    w = np.ones((n, f.size))
    if n == 1:
        return w
    with np.errstate(divide="ignore"):
        lf = np.log2(np.maximum(f, 1e-12))
    edges = 0.5 * (np.log2(centres[:-1]) + np.log2(centres[1:]))
    half = TRANSITION_OCTAVES / 2
    for e, edge in enumerate(edges):
        x = np.clip((lf - (edge - half)) / TRANSITION_OCTAVES, 0.0, 1.0)
        rise = np.sin(0.5 * np.pi * x) ** 2  # upper band's share across this edge
        w[: e + 1] *= 1.0 - rise
        w[e + 1 :] *= rise
    return w


def merge_bands(h_bands: np.ndarray, fs: float, bands_hz) -> np.ndarray:
    """Sum per-band RIRs ``(n_bands, ..., n_taps)`` through the band weights -> ``(..., n_taps)``.

    Example
    -------
    >>> import numpy as np
    >>> h = np.zeros((3, 1, 64)); h[:, 0, 10] = 1.0
    >>> bool(np.allclose(merge_bands(h, 16000, (250, 1000, 4000)), h[0], atol=1e-12))
    True
    """
    h_bands = np.asarray(h_bands, dtype=float)
    centres = check_bands(bands_hz)
    if h_bands.shape[0] != centres.size:
        raise ParameterError("h_bands", h_bands.shape, f"{centres.size} bands on axis 0")
    if centres.size == 1:
        return h_bands[0].copy()
    n_taps = h_bands.shape[-1]
    pad = int(fs // 4)  # > the band filters' ringing, so no circular wrap reaches the taps kept
    n_fft = sfft.next_fast_len(n_taps + 2 * pad, real=True)
    w = band_weights(sfft.rfftfreq(n_fft, 1.0 / fs), centres)
    spec = sfft.rfft(h_bands, n_fft, axis=-1)
    w = w.reshape((centres.size,) + (1,) * (h_bands.ndim - 2) + (w.shape[-1],))
    y = sfft.irfft(np.sum(spec * w, axis=0), n_fft, axis=-1)
    return y[..., :n_taps]
