"""Mismatched microphones for tests, independent of the enhancers' code (and of a scene sensor model).

The rear mic's signal is multiplied by ``r = 10^(g/20) e^{j phi}`` at every positive frequency
(DC and Nyquist take the gain only, so the signal stays real), and each mic may get a first-order
high-pass ``H(f) = j f / (fc + j f)`` (algorithms.md section 4b).  Filtering is circular (rfft), exact
for the periodic signals of ``signals.plane_wave_pair``.
"""

from __future__ import annotations

import numpy as np


def rear_response(freqs_hz, *, gain_db: float = 0.0, phase_deg: float = 0.0,
                  highpass_hz: tuple[float | None, float | None] = (None, None)) -> np.ndarray:
    """Rear-mic response relative to the front one, ``r(f) H2(f) / H1(f)`` (complex, like ``freqs_hz``)."""
    f = np.asarray(freqs_hz, dtype=float)
    r = 10 ** (gain_db / 20) * np.exp(1j * np.radians(phase_deg)) * np.ones_like(f)
    for sign, fc in zip((-1, 1), highpass_hz):
        if fc:
            with np.errstate(divide="ignore", invalid="ignore"):
                h = np.where(f > 0, 1j * f / (fc + 1j * f), 0.0)
            r = r * (h if sign > 0 else np.where(f > 0, 1 / np.where(h == 0, 1, h), 0.0))
    return r


def apply_mismatch(x: np.ndarray, *, fs: int, gain_db: float = 0.0, phase_deg: float = 0.0,
                   highpass_hz: tuple[float | None, float | None] = (None, None)) -> np.ndarray:
    """``(2, n)`` pair with the rear mic times ``10^(g/20) e^{j phi}`` and per-mic high-passes."""
    n = x.shape[-1]
    X = np.fft.rfft(x, axis=-1)
    f = np.fft.rfftfreq(n, 1 / fs)
    r = 10 ** (gain_db / 20) * np.exp(1j * np.radians(phase_deg)) * np.ones(f.shape, dtype=complex)
    r[0] = 10 ** (gain_db / 20)
    if n % 2 == 0:
        r[-1] = 10 ** (gain_db / 20)
    X[1] = X[1] * r
    for i, fc in enumerate(highpass_hz):
        if fc:
            X[i] = X[i] * (1j * f / (fc + 1j * f))
    return np.fft.irfft(X, n=n, axis=-1)
