"""SNR-I split three ways at a stated resolution: fixed spectral EQ, fixed 2-mic filter, time-varying rest.

Resolution rule
---------------
Every long-term spectrum is a one-sided Welch-type estimate (Hann window at hop 1/3: its
squared window sums to a constant, so a spectrum's sum is its signal's power and a ratio of
sums is a time-domain SNR exactly), and every spectral *ratio* is taken between spectra
smoothed in the power domain over a rectangular 1/3-octave window around each bin,
``[f 2^(-1/6), f 2^(1/6)]``, widened to :data:`MIN_BANDWIDTH_HZ` where it is narrower
(fractional-octave smoothing, Hatziantoniou & Mourjopoulos 2000, JAES 48(4)).  A ratio of
smoothed powers does not follow fine structure that only a fine analysis resolves, so the
values no longer depend on the Welch segment (:data:`SEGMENT_S` by default, 2046 points).

Columns (dB; ``snr_i_db`` is the row's time-domain SNR-I)
--------------------------------------------------------
* ``snr_i_fixed_spectral_db`` (:func:`fixed_spectral_snr_i_db`): the SNR-I of one fixed
  single-mic filter on the reference mic with the system's long-term power response
  ``G(f) = sm(S_out) / sm(S_in)`` (``sm(N_out) / sm(N_in)`` in bins without speech,
  :data:`SPEECH_FLOOR`): ``10 lg(sum G S_in / sum S_in) - 10 lg(sum G N_in / sum N_in)``.
* ``snr_i_fixed_spatial_db`` (:func:`snr_i_split`): what the best fixed 2-mic filter ``W(f)``
  adds to that EQ by its directivity.  ``W_c(f)``, channel ``c``'s long-term transfer, is the
  least-squares fit of the system's replayed response to channel ``c`` alone, speech and noise
  jointly, each normalised to unit power::

      W_c = (sum_t Y_sc X_sc* / E_sc + sum_t Y_nc X_nc* / E_nc)
            / (sum_t |X_sc|^2 / E_sc + sum_t |X_nc|^2 / E_nc + lambda max(...))

  (``lambda`` = :data:`TIKHONOV`).  One channel at a time the fit is a scalar per bin and
  well posed; a joint 2x2 fit is not (a point-source talker excites one direction per bin).
  Its per-bin SNR gain, smoothed by the rule, ``D = sm(P_sW N_in) / sm(P_nW S_in)`` with
  ``P_sW = sum_t |sum_c W_c X_sc|^2`` (and ``P_nW`` likewise), is exactly 1 when ``W`` uses one
  mic, whatever its shape (1 too in bins without speech).  Spatial =
  ``10 lg(sum G N_in) - 10 lg(sum G N_in / D)``.
* ``snr_i_time_varying_db`` = ``snr_i_db`` - spectral - spatial: the three sum to ``snr_i_db``
  exactly.  For a fixed (linear, time-invariant) system it is 0 to the rule's resolution:
  features of a fixed response finer than 1/3 octave that meet fine structure of the input
  spectra are booked here too (a 2-tap delay-and-subtract with 20 dB notches: 0.13 dB).

Why new columns: ``snr_i_spectral_db`` and ``snr_i_spatial_db`` keep their definition (an
unsmoothed Welch estimate at :data:`SEGMENT_S`), so stores written before stay one sweep
version and comparable; the rule above is a different quantity and gets its own names.

Sensitivity to the Welch segment (:func:`sensitivity`; ``python -m
benchmarks.metrics.attribution_split``, seed 0, 8 s at 16 kHz): speech-like coloured noise
with a syllabic envelope through the comb ``1 + 0.9 z^-600`` (an echo 37.5 ms late, peaks every
26.7 Hz), noise a 26.7 Hz harmonic series on the comb's peaks.  Over segments 0.064, 0.128,
0.256 s the rule gives 0.026 / 0.025 / 0.109 dB (spread 0.08 dB), the unsmoothed ratio
0.006 / -1.194 / -2.467 dB (2.47 dB), the FIR column ``snr_i_spectral_db`` 2.69 dB.  With the
CMU ARCTIC utterance ``cmu_arctic_a0009`` as the speech: rule -0.700 / -0.780 / -0.715 dB
(0.08 dB), unsmoothed -0.725 / -1.837 / -3.367 dB (2.64 dB), FIR 2.95 dB.
tests/test_attribution_split.py holds the rule to 0.15 dB and the unsmoothed spread to >= 1 dB.

All signals are ``(n_channels, n_samples)`` or 1-D, latency-aligned, one length; ``fs`` in Hz.
"""

from __future__ import annotations

import numpy as np

from benchmarks.metrics.attribution import SEGMENT_S
from scenesim.errors import MetricError, ParameterError

__all__ = [
    "FRACTION",
    "MIN_BANDWIDTH_HZ",
    "SPLIT_COLUMNS",
    "TIKHONOV",
    "fixed_filter",
    "fixed_spectral_snr_i_db",
    "sensitivity",
    "smooth_fractional_octave",
    "snr_i_split",
]

#: Smoothing bandwidth, 1/FRACTION octave.
FRACTION = 3
#: Narrowest smoothing window (Hz): 1/3 octave is narrower below 216 Hz, where a 0.064 s
#: segment's 15.6 Hz bins would leave one bin per window and the rule would follow the segment.
MIN_BANDWIDTH_HZ = 50.0
#: Bins whose smoothed input speech power is below this fraction of its peak (-50 dB) take the
#: EQ's response from the noise: a time-varying gain modulates speech into bins where the talker
#: has almost nothing (DC, above a band limit), and a ratio of near-zero powers there is no EQ.
SPEECH_FLOOR = 1e-5
#: Tikhonov term of the per-channel fit, relative to the largest bin's normal equation.
TIKHONOV = 1e-8
#: Lowest per-bin SNR gain ``D`` of the fixed filter (-60 dB): a fixed filter that passes no
#: speech in a band where the system does is booked as 60 dB worse there, not as -inf.
D_FLOOR = 1e-6
#: Delay of the echo in :func:`sensitivity`'s comb filter (samples at 16 kHz).
ECHO_SAMPLES = 600
#: The columns of :func:`snr_i_split`.
SPLIT_COLUMNS = ("snr_i_fixed_spectral_db", "snr_i_fixed_spatial_db", "snr_i_time_varying_db")


def _nperseg(fs: int, segment_s: float) -> int:
    if not segment_s > 0:
        raise ParameterError("segment_s", segment_s, "a positive duration in seconds")
    # The power of two nearest the segment, trimmed to a multiple of 6: an even length whose
    # third is the hop of :func:`_stft`.
    return max(6, 6 * (int(2 ** int(np.round(np.log2(segment_s * fs)))) // 6))


def _stft(x, nperseg: int) -> np.ndarray:
    """One-sided spectra ``(..., frames, bins)`` with ``sum |X|^2 = sum x^2`` (Parseval).

    Hann window ``w = sin^2(pi (n + 1/2) / N)`` at hop ``N / 3``: ``w^2 = sin^4`` sums to 9/8
    over the three frames covering a sample (its harmonics 2 and 4 cancel), and its sidelobes
    fall 18 dB per octave, so a band without speech is not filled by leakage from one with it.
    The signal is padded by ``N - hop`` each side, so every sample counts equally.
    """
    from scipy import fft as sfft  # lazy, as in benchmarks.metrics.attribution

    x = np.asarray(x, dtype=np.float64)
    hop = nperseg // 3
    edge = nperseg - hop
    n_frames = -(-(x.shape[-1] + edge) // hop)  # the last frame starts at or after the signal's end
    pad = [(0, 0)] * (x.ndim - 1) + [(edge, n_frames * hop + nperseg - edge - x.shape[-1])]
    frames = np.lib.stride_tricks.sliding_window_view(np.pad(x, pad), nperseg, axis=-1)[..., ::hop, :]
    window = np.sin(np.pi * (np.arange(nperseg) + 0.5) / nperseg) ** 2 / np.sqrt(1.125 * nperseg)
    spec = sfft.rfft(frames * window, axis=-1, overwrite_x=True)
    spec[..., 1:-1] *= np.sqrt(2.0)  # one-sided: the negative frequencies' power
    return spec


def smooth_fractional_octave(p, df_hz: float, *, fraction: int | None = FRACTION,
                             min_bandwidth_hz: float = MIN_BANDWIDTH_HZ) -> np.ndarray:  # fmt: skip
    """Mean of ``p`` (last axis: bins ``k df_hz``) over ``[f 2^(-1/2b), f 2^(1/2b)]``, ``b = fraction``.

    A window narrower than ``min_bandwidth_hz`` is widened to it, centred on ``f`` (clipped at
    0 Hz); bins are in the window when their centre is.  ``fraction=None`` returns ``p``.

    >>> p = np.array([5.0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9, 0, 0])
    >>> smooth_fractional_octave(p, 1.0, fraction=3, min_bandwidth_hz=0.0)[[0, 9, 10, 11]]
    array([5. , 4.5, 3. , 3. ])
    >>> smooth_fractional_octave(p, 1.0, fraction=3, min_bandwidth_hz=4.0)[[0, 1]]   # 0-2 Hz, 0-3 Hz
    array([1.66666667, 1.25      ])
    """
    p = np.asarray(p, dtype=np.float64)
    if fraction is None:
        return p
    f = np.arange(p.shape[-1], dtype=np.float64) * df_hz
    half = 2.0 ** (0.5 / fraction)
    width = np.maximum(f * (half - 1.0 / half), min_bandwidth_hz)
    centre = np.where(f * (half - 1.0 / half) >= min_bandwidth_hz, f * (half + 1.0 / half) / 2.0, f)
    k = np.arange(p.shape[-1])
    lo = np.minimum(np.clip(np.ceil((centre - width / 2.0) / df_hz - 1e-9), 0, None).astype(int), k)
    hi = np.maximum(np.minimum(np.floor((centre + width / 2.0) / df_hz + 1e-9), k[-1]).astype(int), k)
    csum = np.concatenate([np.zeros(p.shape[:-1] + (1,)), np.cumsum(p, axis=-1)], axis=-1)
    return (csum[..., hi + 1] - csum[..., lo]) / (hi - lo + 1)


def _sm(p, rule) -> np.ndarray:
    return smooth_fractional_octave(p, rule[0], fraction=rule[1])


def _power(spec) -> np.ndarray:
    return np.sum(np.abs(spec) ** 2, axis=-2)


def _lg(num: float, den: float, what: str) -> float:
    if not (num > 0.0 and den > 0.0):
        raise MetricError(f"attribution split: silent {what}")
    return float(10.0 * np.log10(num / den))


def _response(spectra, rule) -> tuple[np.ndarray, np.ndarray]:
    """``(G, speech)``: the EQ's power response per bin and where the input has speech.

    ``spectra = (S_in, N_in, S_out, N_out)`` as ``(frames, bins)``; ``rule = (df_hz,
    fraction)`` (:func:`smooth_fractional_octave`).  ``G = sm(S_out) / sm(S_in)`` where
    ``sm(S_in)`` is above :data:`SPEECH_FLOOR` of its peak; elsewhere no talker tells what the
    system does, the noise does: ``G = sm(N_out) / sm(N_in)``.
    """
    s_in, n_in, s_out, n_out = (_sm(_power(x), rule) for x in spectra)
    speech = s_in > SPEECH_FLOOR * max(float(s_in.max()), 1e-300)
    g = np.divide(n_out, n_in, out=np.zeros_like(n_in), where=n_in > 0.0)
    np.divide(s_out, s_in, out=g, where=speech)
    return g, speech


def _spectral_db(g, s_in_pow, n_in_pow) -> float:
    return _lg(float(g @ s_in_pow), float(s_in_pow.sum()), "speech") - _lg(float(g @ n_in_pow), float(n_in_pow.sum()), "noise")


def fixed_spectral_snr_i_db(s_in, n_in, s_out, n_out, fs: int, *, segment_s: float = SEGMENT_S,
                            fraction: int | None = FRACTION) -> float:  # fmt: skip
    """SNR-I (dB) of the fixed single-mic EQ with the system's smoothed speech response (1-D inputs).

    ``fraction=None``: the same without smoothing (the resolution-dependent estimate).

    >>> rng = np.random.default_rng(1)
    >>> s, n = rng.standard_normal(16000), rng.standard_normal(16000)
    >>> round(fixed_spectral_snr_i_db(s, n, 0.3 * s, 0.3 * n, 16000), 6) + 0.0   # a gain shapes nothing
    0.0
    """
    nper = _nperseg(fs, segment_s)
    s_spec, n_spec = _stft(s_in, nper), _stft(n_in, nper)
    g, _ = _response((s_spec, n_spec, _stft(s_out, nper), _stft(n_out, nper)), (fs / nper, fraction))
    return _spectral_db(g, _power(s_spec), _power(n_spec))


def fixed_filter(x_s, y_s, x_n, y_n) -> np.ndarray:
    """Per-channel least-squares transfer ``W (channels, bins)`` from spectra ``(channels, frames, bins)``.

    ``x_*`` the input speech / noise, ``y_*`` the system's response to each channel alone.
    """
    e_s = np.maximum(np.sum(np.abs(x_s) ** 2, axis=(-2, -1)), 1e-300)[:, None]
    e_n = np.maximum(np.sum(np.abs(x_n) ** 2, axis=(-2, -1)), 1e-300)[:, None]
    num = np.sum(y_s * np.conj(x_s), axis=-2) / e_s + np.sum(y_n * np.conj(x_n), axis=-2) / e_n
    den = _power(x_s) / e_s + _power(x_n) / e_n
    return num / (den + TIKHONOV * np.max(den, axis=-1, keepdims=True))


def _spatial_db(response, w, spectra, rule) -> float:
    """``10 lg(sum G N_in) - 10 lg(sum G N_in / D)`` with ``D`` the fixed filter's smoothed SNR gain
    where the input has speech, 1 where it has none (``response = (G, speech)``)."""
    (g, speech), (x_s, x_n) = response, spectra
    p_sw, p_nw = _power(np.sum(w[:, None, :] * x_s, axis=0)), _power(np.sum(w[:, None, :] * x_n, axis=0))
    s_in, n_in = _power(x_s[0]), _power(x_n[0])
    num = _sm(p_sw * n_in, rule)
    den = _sm(p_nw * s_in, rule)
    d = np.maximum(np.divide(num, den, out=np.ones_like(num), where=speech & (den > 0.0)), D_FLOOR)
    return _lg(float(g @ n_in), float((g / d) @ n_in), "noise through the fixed filter")


def snr_i_split(s_in, n_in, s_parts, n_parts, fs: int, *, snr_i_db: float,
                segment_s: float = SEGMENT_S, fraction: int | None = FRACTION) -> dict[str, float]:  # fmt: skip
    """:data:`SPLIT_COLUMNS` of a replayable system (see the module docstring).

    ``s_in, n_in``: input speech and noise ``(channels, n)`` as the system took them, reference
    mic first; ``s_parts, n_parts``: the system's aligned first output replayed on each input
    channel alone ``(channels, n)`` (their sums are the output's speech and noise parts).

    A talker at broadside (the same speech at both mics), independent noise, the mics' mean:

    >>> rng = np.random.default_rng(3)
    >>> s, n = np.tile(rng.standard_normal(32000), (2, 1)), rng.standard_normal((2, 32000))
    >>> total = 10 * np.log10(np.sum(s[0] ** 2) / np.sum((0.5 * n.sum(0)) ** 2) * np.sum(n[0] ** 2) / np.sum(s[0] ** 2))
    >>> out = snr_i_split(s, n, 0.5 * s, 0.5 * n, 16000, snr_i_db=total)
    >>> [round(out[k], 1) + 0.0 for k in SPLIT_COLUMNS]   # 3 dB: two mics average white noise
    [0.0, 3.0, 0.0]
    """
    s_in, n_in = np.atleast_2d(s_in), np.atleast_2d(n_in)
    s_parts, n_parts = np.atleast_2d(s_parts), np.atleast_2d(n_parts)
    if not s_in.shape == n_in.shape == s_parts.shape == n_parts.shape:
        raise ParameterError("s_parts", s_parts.shape, f"the input's shape {s_in.shape}")
    nper = _nperseg(fs, segment_s)
    x_s, x_n = _stft(s_in, nper), _stft(n_in, nper)
    y_s, y_n = _stft(s_parts, nper), _stft(n_parts, nper)
    rule = (fs / nper, fraction)
    response = _response((x_s[0], x_n[0], np.sum(y_s, axis=0), np.sum(y_n, axis=0)), rule)
    spectral = _spectral_db(response[0], _power(x_s[0]), _power(x_n[0]))
    spatial = _spatial_db(response, fixed_filter(x_s, y_s, x_n, y_n), (x_s, x_n), rule)
    return dict(zip(SPLIT_COLUMNS, (spectral, spatial, float(snr_i_db) - spectral - spatial)))


def _comb_pair(rng, speech=None, fs: int = 16000, duration_s: float = 8.0):
    """``(s_in, n_in, s_out, n_out)``: speech (or speech-like coloured noise with a 4 Hz syllabic
    envelope) through the comb ``1 + 0.9 z^-600`` (an echo 37.5 ms late: peaks every 26.7 Hz,
    which a 0.064 s segment does not resolve and a 0.256 s one does); noise a 26.7 Hz harmonic
    series (on the comb's peaks) over -20 dB white noise."""
    from scipy.signal import lfilter

    n = int(duration_s * fs) if speech is None else speech.size
    t = np.arange(n) / fs
    if speech is None:
        coloured = lfilter([1.0], [1.0, -0.9], rng.standard_normal(n))  # speech-like -6 dB/oct tilt
        speech = coloured * (0.2 + np.clip(np.sin(2 * np.pi * 4.0 * t), 0.0, None) ** 2)
    f0 = fs / ECHO_SAMPLES
    harmonics = sum(np.cos(2 * np.pi * f0 * k * t + rng.uniform(0, 2 * np.pi)) / np.sqrt(k) for k in range(1, 150))
    noise = harmonics + 0.1 * np.std(harmonics) * rng.standard_normal(n)
    comb = np.zeros(ECHO_SAMPLES + 1)
    comb[[0, ECHO_SAMPLES]] = 1.0, 0.9
    return speech, noise, lfilter(comb, [1.0], speech), lfilter(comb, [1.0], noise)


def sensitivity(seed: int = 0, speech=None, segments_s=(0.064, 0.128, 0.256)) -> dict[str, list[float]]:
    """Spectral SNR-I (dB) of :func:`_comb_pair` per Welch segment: ``"rule"`` (1/3 octave),
    ``"unsmoothed"`` (``fraction=None``) and ``"fir"`` (the unsmoothed ``snr_i_spectral_db``)."""
    from benchmarks.metrics import attribution

    s, n, y, yn = _comb_pair(np.random.default_rng(seed), speech)
    out: dict[str, list[float]] = {"rule": [], "unsmoothed": [], "fir": []}
    kept = attribution.SEGMENT_S
    try:
        for seg in segments_s:
            out["rule"].append(fixed_spectral_snr_i_db(s, n, y, yn, 16000, segment_s=seg))
            out["unsmoothed"].append(fixed_spectral_snr_i_db(s, n, y, yn, 16000, segment_s=seg, fraction=None))
            attribution.SEGMENT_S = seg  # the FIR column reads its segment from the module
            out["fir"].append(attribution.snr_i_spectral_db(s, n, y, 16000))
    finally:
        attribution.SEGMENT_S = kept
    return out


if __name__ == "__main__":  # prints the sensitivity table of the module docstring
    for name, values in sensitivity().items():
        print(f"{name:11s}", " ".join(f"{v:7.3f}" for v in values), f"spread {np.ptp(values):.3f} dB")
