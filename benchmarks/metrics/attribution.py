"""Where a system's SNR improvement comes from: fixed spectral shaping vs the rest, per octave.

* :func:`snr_i_spectral_db` -- the SNR-I that one fixed linear-phase FIR on the reference mic
  gives when its magnitude is the system's long-term speech response
  ``|H(f)| = sqrt(S_out(f) / S_in(f))`` (Welch PSDs of the output's speech part and of the
  speech at the reference mic).  That is what any single-mic fixed EQ with the same effect on
  the talker's spectrum would give; ``snr_i_db - snr_i_spectral_db`` (``snr_i_spatial_db``)
  is what is left for the array (and for time-varying gains).  For a single-mic fixed filter
  the two are equal (to the resolution of the PSD estimate).
* :func:`octave_snr_i` -- SNR-I per octave band (125 Hz - 4 kHz), and with sensor self-noise
  the per-band limit of a linear 2-mic system: the speech-to-self-noise ratio of the band at
  the reference mic plus ``10 log10 2`` (white-noise gain <= 2), re the band's input SNR.
  Strictly the limit holds per frequency bin; over an octave it holds when speech and
  self-noise spectra have the same shape within the band.

All signals are 1-D, one length, latency-aligned (the caller's job); ``fs`` in Hz.
"""

from __future__ import annotations

import numpy as np

from scenesim.errors import MetricError

__all__ = [
    "OCTAVE_CENTRES_HZ",
    "SELF_NOISE_ARRAY_GAIN_DB",
    "long_term_psd",
    "octave_snr_i",
    "snr_i_spectral_db",
    "spectral_fir",
]

#: Octave-band centres (Hz) of the per-band SNR-I; a band is kept when its top edge < fs/2.
OCTAVE_CENTRES_HZ = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0)
#: White-noise gain of two mics, 10 log10 2 dB (the self-noise bound per bin).
SELF_NOISE_ARRAY_GAIN_DB = 10.0 * np.log10(2.0)
#: Welch segment length (s); 2048 points at 16 kHz, 7.8 Hz bins: 11 bins in the 125 Hz octave.
SEGMENT_S = 0.128
#: PSD bins below this fraction of the input speech PSD's peak get no defined response (0 gain).
RESPONSE_FLOOR = 1e-10


def _nperseg(fs: int, n: int) -> int:
    return int(min(n, 2 ** int(np.round(np.log2(SEGMENT_S * fs)))))


def long_term_psd(x, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """``(freqs_hz, psd)`` of the 1-D signal ``x``: Welch, Hann, 50 % overlap, :data:`SEGMENT_S`.

    >>> f, p = long_term_psd(np.ones(4096), 16000)
    >>> f.size, float(p[2:].max()) < 1e-20   # a constant: DC and the Hann window's next bin only
    (1025, True)
    """
    x = np.asarray(x, dtype=np.float64)
    from scipy.signal import (
        welch,  # lazy: scipy.signal costs ~1 s to import; the store needs none of it
    )

    return welch(x, fs=fs, nperseg=_nperseg(fs, x.size), detrend=False)


def spectral_fir(s_in, s_out, fs: int) -> np.ndarray:
    """Linear-phase FIR (odd length) with magnitude ``sqrt(S_out / S_in)``, the long-term speech response.

    >>> rng = np.random.default_rng(0)
    >>> s = rng.standard_normal(16000)
    >>> h = spectral_fir(s, 0.5 * s, 16000)
    >>> h.size % 2 == 1, round(float(h.sum()), 6)   # a flat response: a delayed 0.5
    (True, 0.5)
    """
    f, p_in = long_term_psd(s_in, fs)
    _, p_out = long_term_psd(s_out, fs)
    ok = p_in > RESPONSE_FLOOR * max(float(p_in.max()), 1e-300)
    gain = np.zeros_like(p_in)
    gain[ok] = np.sqrt(p_out[ok] / p_in[ok])
    from scipy.signal import firwin2  # lazy, as welch above

    return firwin2(2 * (f.size - 1) + 1, f, gain, fs=fs, window=None)


def _snr_db(s: np.ndarray, n: np.ndarray) -> float:
    ps, pn = float(np.sum(s * s)), float(np.sum(n * n))
    if ps <= 0.0 or pn <= 0.0:
        raise MetricError("spectral SNR: silent speech or noise")
    return float(10.0 * np.log10(ps / pn))


def snr_i_spectral_db(s_in, n_in, s_out, fs: int) -> float:
    """SNR-I (dB) of ``(s_in, n_in)`` through :func:`spectral_fir` (the speech response of ``s_out``).

    >>> rng = np.random.default_rng(1)
    >>> s, n = rng.standard_normal(16000), rng.standard_normal(16000)
    >>> round(float(snr_i_spectral_db(s, n, 0.3 * s, 16000)), 6) + 0.0   # a gain shapes nothing
    0.0
    """
    s_in, n_in = np.asarray(s_in, dtype=np.float64), np.asarray(n_in, dtype=np.float64)
    h = spectral_fir(s_in, s_out, fs)
    # Full convolutions: every sample of both filtered signals counts, edges included.
    from scipy.signal import fftconvolve  # lazy, as welch above

    return float(_snr_db(fftconvolve(s_in, h), fftconvolve(n_in, h)) - _snr_db(s_in, n_in))


def _band_powers(x, fs: int, centres) -> np.ndarray:
    f, p = long_term_psd(x, fs)
    return np.array([p[(f >= c / np.sqrt(2.0)) & (f < c * np.sqrt(2.0))].sum() for c in centres])


def _db(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    return 10.0 * np.log10(np.maximum(num, 1e-300) / np.maximum(den, 1e-300))


def octave_snr_i(s_in, n_in, s_out, n_out, fs: int, self_noise=None) -> dict[str, list]:
    """Per-octave SNR-I; JSON-ready ``{"centre_hz", "snr_i_db", "self_noise_limit_db"}``.

    ``self_noise_limit_db`` (None without ``self_noise``, the self-noise at the reference mic):
    the highest per-band SNR-I a linear 2-mic system reaches when self-noise is all that is
    left: ``SSNR_in(band) + 10 log10 2 - SNR_in(band)``.

    >>> rng = np.random.default_rng(2)
    >>> s, n = rng.standard_normal(32000), rng.standard_normal(32000)
    >>> d = octave_snr_i(s, n, s, 0.5 * n, 16000)
    >>> d["centre_hz"][0], [round(v, 2) for v in d["snr_i_db"]]   # 6.02 dB in every band
    (125.0, [6.02, 6.02, 6.02, 6.02, 6.02, 6.02])
    """
    centres = [c for c in OCTAVE_CENTRES_HZ if c * np.sqrt(2.0) < fs / 2.0]
    si, ni = _band_powers(s_in, fs, centres), _band_powers(n_in, fs, centres)
    so, no = _band_powers(s_out, fs, centres), _band_powers(n_out, fs, centres)
    snr_in = _db(si, ni)
    out = {"centre_hz": centres, "snr_i_db": [float(v) for v in _db(so, no) - snr_in],
           "self_noise_limit_db": None}  # fmt: skip
    if self_noise is not None and np.any(self_noise):
        limit = _db(si, _band_powers(self_noise, fs, centres)) + SELF_NOISE_ARRAY_GAIN_DB - snr_in
        out["self_noise_limit_db"] = [float(v) for v in limit]
    return out
