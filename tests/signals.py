"""Test signals with exact oracles, independent of the project's own delay/filter code.

Plane waves on the two-mic pair are built with an exact FFT-domain (circular) delay, so the
delays are exact for the periodic extension of the source signal.
"""

from __future__ import annotations

import numpy as np

FS = 16000
SPACING_M = 0.0214
C_MPS = 343.0


def fft_delay(s: np.ndarray, delay_samples) -> np.ndarray:
    """Circularly delay the real 1-D ``s`` by (possibly fractional) ``delay_samples`` (exact in the DFT sense).

    ``delay_samples`` may be an array: returns one row per delay.  The Nyquist bin of ``s``
    is dropped so the result stays real for any fractional delay.
    """
    n = s.shape[-1]
    S = np.fft.rfft(s)
    if n % 2 == 0:
        S[-1] = 0.0
    k = np.arange(S.shape[-1])
    d = np.atleast_1d(np.asarray(delay_samples, dtype=float))[:, None]
    out = np.fft.irfft(S * np.exp(-2j * np.pi * k * d / n), n=n)
    return out if np.ndim(delay_samples) else out[0]


def plane_wave_pair(s: np.ndarray, *, az_deg: float = 0.0, el_deg: float = 0.0, spacing_m: float = SPACING_M,
                    c_mps: float = C_MPS, fs: int = FS) -> np.ndarray:
    """Far-field plane wave of ``s`` arriving from (az, el) at the pair: ``(2, n)``, rows p1 (front), p2 (rear).

    Mic i at ``r_i = +-(d/2) axis`` receives ``s(t - tau_i)``, ``tau_i = -(r_i . u) / c`` (algorithms.md
    section 2), with ``cos(angle to axis) = cos(el) cos(az)``.
    """
    cos_axis = np.cos(np.radians(el_deg)) * np.cos(np.radians(az_deg))
    half = 0.5 * spacing_m * cos_axis / c_mps * fs
    return fft_delay(s, np.array([-half, half]))


def lowpass_noise(n: int, *, cutoff_hz: float, rng: np.random.Generator, fs: int = FS,
                  lo_hz: float = 0.0) -> np.ndarray:
    """Unit-variance white Gaussian noise band-limited to ``[lo_hz, cutoff_hz]`` by zeroing DFT bins."""
    S = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / fs)
    S[(f > cutoff_hz) | (f < lo_hz)] = 0.0
    x = np.fft.irfft(S, n=n)
    return x / np.std(x)


def cardioid_pair(p: np.ndarray, *, delay_samples: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact (FFT-domain) back-to-back cardioids ``cF = p1 - p2(n-T)``, ``cB = p2 - p1(n-T)``."""
    return p[0] - fft_delay(p[1], delay_samples), p[1] - fft_delay(p[0], delay_samples)


def harmonic_speechlike(n: int, *, fs: int = FS, f0_hz: float = 150.0, n_harm: int = 20,
                        syllable_hz: float = 4.0, pause_every_s: float = 1.0, pause_s: float = 0.4) -> np.ndarray:
    """Amplitude-modulated harmonic complex with pauses: a deterministic speech-like test signal.

    150 Hz fundamental, 20 harmonics (1/h amplitudes), 4 Hz raised-cosine syllable envelope,
    silent for the last ``pause_s`` of every ``pause_every_s`` (40 % pauses by default,
    like read speech with phrase breaks).
    """
    t = np.arange(n) / fs
    harm = np.arange(1, n_harm + 1)
    amp = 1.0 / harm
    tone = (amp[:, None] * np.sin(2 * np.pi * f0_hz * harm[:, None] * t + harm[:, None] ** 2)).sum(axis=0)
    env = 0.5 * (1 - np.cos(2 * np.pi * syllable_hz * t))
    env[(t % pause_every_s) > pause_every_s - pause_s] = 0.0
    return tone * env
