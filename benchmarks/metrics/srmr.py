"""Speech-to-reverberation modulation energy ratio (SRMR; Falk, Zheng & Chan 2010).

A non-intrusive measure of reverberation: speech modulates its envelope mostly at
2-20 Hz, reverberation fills the envelope's higher modulation frequencies.  SRMR is the
energy of the four lowest modulation bands (4-~20 Hz) over that of the next ones
(up to the band K* set by the signal's acoustic bandwidth), summed over 23 gammatone
bands.  Higher is less reverberant.

Steps (Falk et al. 2010, IEEE TASLP 18(7), 1766-1774, sections III-A..C; the MATLAB
toolbox's "slow" variant, which SRMRpy's ``fast=False`` reproduces):

1. 23 fourth-order gammatone filters (Slaney's four-biquad design), centre
   frequencies ERB-spaced from 125 Hz to fs/2 (Glasberg & Moore: EarQ 9.26449, minBW 24.7);
2. Hilbert envelope of each band (the FFT length rounded up to a multiple of 16, as the
   reference does);
3. 8 second-order band-pass modulation filters, Q = 2, centres log-spaced 4..128 Hz,
   applied at the audio rate;
4. energies in 256 ms periodic-Hamming frames every 64 ms, averaged over frames;
5. K* from the bandwidth: the ERB of the band where the cumulative energy (from the
   lowest band) first exceeds 90 %, compared with the lower 3 dB cut-offs of modulation
   bands 5..8; ``SRMR = sum(E[:, :4]) / sum(E[:, 4:K*])``.

Validated (tests/test_srmr.py) against the ratio published with SRMRpy's test data, which
was computed by the authors' MATLAB toolbox.  Written here because no maintained PyPI
package computes it without torch or an unpublished gammatone fork.
"""

from __future__ import annotations

import functools

import numpy as np

from scenesim.errors import ParameterError

N_COCHLEAR = 23
LOW_FREQ_HZ = 125.0
MOD_MIN_HZ = 4.0
MOD_MAX_HZ = 128.0
N_MOD = 8
MOD_Q = 2.0
FRAME_S = 0.256
HOP_S = 0.064
_EAR_Q = 9.26449
_MIN_BW = 24.7


def erb_centre_freqs(fs: int, n: int = N_COCHLEAR, low_hz: float = LOW_FREQ_HZ) -> np.ndarray:
    """ERB-spaced centre frequencies (Hz), highest first, from fs/2 down to ``low_hz`` (Slaney 1993)."""
    hi = fs / 2.0
    k = np.arange(1, n + 1)
    step = (np.log(low_hz + _EAR_Q * _MIN_BW) - np.log(hi + _EAR_Q * _MIN_BW)) / n
    return -(_EAR_Q * _MIN_BW) + np.exp(k * step) * (hi + _EAR_Q * _MIN_BW)


def modulation_centre_freqs() -> np.ndarray:
    """The 8 modulation filters' centre frequencies (Hz), log-spaced 4..128."""
    return MOD_MIN_HZ * (MOD_MAX_HZ / MOD_MIN_HZ) ** (np.arange(N_MOD) / (N_MOD - 1))


def _modulation_ba(cf_hz: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    # Bilinear-transformed second-order band-pass of quality MOD_Q (Falk 2010, sec. III-B).
    w0 = np.tan(np.pi * cf_hz / fs)
    b0 = w0 / MOD_Q
    return np.array([b0, 0.0, -b0]), np.array([1 + b0 + w0**2, 2 * w0**2 - 2, 1 - b0 + w0**2])


def gammatone_sos(cf_hz: float, fs: int) -> np.ndarray:
    """Slaney's fourth-order gammatone as 4 biquads ``(4, 6)`` with unit gain at ``cf_hz``.

    Slaney (1993), "An efficient implementation of the Patterson-Holdsworth auditory filter
    bank", Apple TR 35: bandwidth ``b = 1.019 * 2 pi * ERB(cf)``, poles
    ``exp(-bT +- j 2 pi cf T)`` shared by four sections whose zeros are
    ``cos(arg) +- sqrt(3 +- 2^1.5) sin(arg)`` (scaled), the cascade normalised at ``cf``.
    """
    from scipy import signal as sps  # lazy: ~1 s to import; the store and report need none of it
    t = 1.0 / fs
    erb = cf_hz / _EAR_Q + _MIN_BW
    b = 1.019 * 2.0 * np.pi * erb
    arg = 2.0 * np.pi * cf_hz * t
    den = np.array([1.0, -2.0 * np.cos(arg) * np.exp(-b * t), np.exp(-2.0 * b * t)])
    sos = np.empty((4, 6))
    for k, (r, sign) in enumerate(((3 + 2**1.5, 1), (3 + 2**1.5, -1), (3 - 2**1.5, 1), (3 - 2**1.5, -1))):
        a1 = -t * np.exp(-b * t) * (np.cos(arg) + sign * np.sqrt(r) * np.sin(arg))
        sos[k] = [t, a1, 0.0, *den]
    _, h = sps.sosfreqz(sos, worN=[cf_hz], fs=fs)
    sos[0, :3] /= np.abs(h[0])
    return sos


@functools.lru_cache(maxsize=8)
def _gammatone_bank(fs: int) -> tuple[np.ndarray, ...]:
    """The 23 gammatone filters at ``fs``, highest band first: designed once per rate, not per call."""
    return tuple(gammatone_sos(cf, fs) for cf in erb_centre_freqs(fs))  # sosfilt only reads them


def _envelopes(x: np.ndarray, fs: int) -> np.ndarray:
    """Hilbert envelopes ``(23, n16)`` of the gammatone bands, highest band first."""
    from scipy import signal as sps  # lazy: ~1 s to import; the store and report need none of it
    bands = np.empty((N_COCHLEAR, x.size))
    for i, sos in enumerate(_gammatone_bank(int(fs))):
        bands[i] = sps.sosfilt(sos, x)
    n_fft = int(np.ceil(x.size / 16) * 16)
    return np.abs(sps.hilbert(bands, N=n_fft, axis=-1))


def _frame_energies(p: np.ndarray, w2: np.ndarray, hop: int, n_frames: int) -> np.ndarray:
    """``E[c, f] = sum_k w2[k] p[c, f hop + k]`` for ``f < n_frames`` (exact).

    When the window is a whole number of hops (256 / 64 ms at 8 and 16 kHz) the sum is split
    into hop-long blocks: one contiguous matmul instead of a copy of every frame.
    """
    win = w2.size
    if win % hop == 0:
        q = win // hop
        n_blocks = n_frames + q - 1
        blocks = p[:, : n_blocks * hop].reshape(p.shape[0], n_blocks, hop) @ w2.reshape(q, hop).T
        return sum(blocks[:, j : j + n_frames, j] for j in range(q))
    view = np.lib.stride_tricks.as_strided(
        p, shape=(p.shape[0], n_frames, win), strides=(p.strides[0], hop * p.strides[1], p.strides[1]), writeable=False
    )
    return view @ w2


def modulation_energy(x, fs: int) -> np.ndarray:
    """Frame-averaged modulation energies ``(23 acoustic bands, highest first; 8 modulation bands)``."""
    from scipy import signal as sps  # lazy: ~1 s to import; the store and report need none of it
    env = _envelopes(x, fs)
    win = int(np.ceil(FRAME_S * fs))
    hop = int(np.ceil(HOP_S * fs))
    n_frames = 1 + (env.shape[1] - win) // hop
    w2 = sps.windows.hamming(win, sym=False) ** 2
    out = np.empty((N_COCHLEAR, N_MOD))
    for j, cf in enumerate(modulation_centre_freqs()):
        b, a = _modulation_ba(cf, fs)
        mod = sps.sosfilt(np.concatenate([b, a])[None, :] / a[0], env, axis=-1)
        out[:, j] = np.mean(_frame_energies(np.ascontiguousarray(mod**2), w2, hop, n_frames), axis=-1)
    return out


def _k_star(energy: np.ndarray, fs: int) -> int:
    """Number of modulation bands kept (5..8) from the 90 % acoustic bandwidth (Falk 2010, eq. 6)."""
    per_band = energy.sum(axis=1)[::-1]  # lowest acoustic band first
    cum = np.cumsum(per_band) / np.sum(per_band)
    idx = int(np.nonzero(cum > 0.9)[0][0])
    bw = (erb_centre_freqs(fs)[::-1][idx] / _EAR_Q) + _MIN_BW  # ERB of that band
    cfs = modulation_centre_freqs()
    lower_cut = cfs - np.tan(np.pi * cfs / fs) / MOD_Q * fs / np.pi  # lower 3 dB edges
    k = 5
    for band in (5, 6, 7):  # 0-based index of the 6th..8th filter
        if bw > lower_cut[band]:
            k = band + 1
    return k


def srmr(x, fs: int) -> float:
    """SRMR of a mono signal (dimensionless ratio; higher = less reverberant).

    Parameters
    ----------
    x : array (n,)
        Speech, at least one 256 ms frame long.
    fs : int
        Sampling rate in Hz (validated at 8 and 16 kHz, like the reference).

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(16000) / 16000
    >>> x = np.sin(2 * np.pi * 500 * t) * (1 + np.sin(2 * np.pi * 4 * t))
    >>> srmr(x, 16000) > 10   # slow modulation only
    True
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ParameterError("x", x, "a finite mono signal (n,)")
    if x.size < int(np.ceil(FRAME_S * fs)) or not np.any(x):
        raise ParameterError("x", x, f"a non-silent signal of at least {FRAME_S} s")
    energy = modulation_energy(x, int(fs))
    k = _k_star(energy, int(fs))
    return float(np.sum(energy[:, :4]) / np.sum(energy[:, 4:k]))


__all__ = ["erb_centre_freqs", "modulation_centre_freqs", "modulation_energy", "srmr"]
