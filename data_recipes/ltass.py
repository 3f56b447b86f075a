"""The long-term average speech spectrum (LTASS) used as the speech-shaped reference.

Source: Byrne, Dillon, Tran et al. (1994), "An international comparison of long-term
average speech spectra", J. Acoust. Soc. Am. 96(4), 2108-2120: the "universal" LTASS
(male and female talkers combined) in one-third-octave bands, for an overall level of
70 dB SPL.  Both the artificial voice (its fixed equaliser) and the ``speech-shaped``
noise follow this table.
"""

from __future__ import annotations

import numpy as np

#: One-third-octave band centre frequencies (Hz) of the Byrne et al. (1994) table.
BYRNE_1994_CENTERS_HZ = np.array(
    [63, 80, 100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250, 1600,
     2000, 2500, 3150, 4000, 5000, 6300, 8000, 10000, 12500, 16000],
    dtype=float,
)
#: Band levels (dB SPL, overall 70 dB), universal LTASS, Byrne et al. (1994).
BYRNE_1994_LEVELS_DB = np.array(
    [38.6, 43.5, 54.4, 57.7, 56.8, 60.2, 60.3, 59.0, 62.1, 62.1, 60.5, 56.8, 53.7,
     53.0, 52.0, 48.7, 48.1, 46.8, 45.6, 44.5, 44.3, 43.7, 43.4, 41.3, 40.7],
    dtype=float,
)


def third_octave_edges_hz(centers_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper band edges ``fc * 2**(-1/6)``, ``fc * 2**(1/6)`` of 1/3-octave bands."""
    centers_hz = np.asarray(centers_hz, dtype=float)
    return centers_hz * 2.0 ** (-1 / 6), centers_hz * 2.0 ** (1 / 6)


def ltass_psd_db(freqs_hz: np.ndarray) -> np.ndarray:
    """Speech-shaped power spectral density (dB re 1 per Hz, arbitrary offset) at ``freqs_hz``.

    The band level ``L_b`` of a 1/3-octave band of width ``B = fc (2**(1/6) - 2**(-1/6))``
    corresponds to the density ``L_b - 10 log10(B)``; the densities are interpolated
    linearly on a log-frequency axis and held constant beyond the table's ends.
    """
    lo, hi = third_octave_edges_hz(BYRNE_1994_CENTERS_HZ)
    density_db = BYRNE_1994_LEVELS_DB - 10.0 * np.log10(hi - lo)
    f = np.maximum(np.asarray(freqs_hz, dtype=float), 1e-3)
    return np.interp(np.log(f), np.log(BYRNE_1994_CENTERS_HZ), density_db)


def band_levels_db(x: np.ndarray, fs: int, centers_hz: np.ndarray, *, nperseg: int = 2048) -> np.ndarray:
    """One-third-octave band levels (dB, arbitrary reference) of a 1-D signal via Welch's PSD.

    Each band's power is the integral of the Welch PSD (Hann window, 50 % overlap)
    between the band edges; a 1e-30 floor keeps silent bands finite.
    """
    from scipy.signal import welch

    f, pxx = welch(np.asarray(x, dtype=float), fs=fs, nperseg=nperseg)
    lo, hi = third_octave_edges_hz(centers_hz)
    df = f[1] - f[0]
    inside = (f[None, :] >= lo[:, None]) & (f[None, :] < hi[:, None])
    power = (inside * pxx[None, :]).sum(axis=1) * df
    return 10.0 * np.log10(np.maximum(power, 1e-30))
