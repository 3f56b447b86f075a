"""Pure metric functions: SNR, segmental SNR, SI-SDR, PESQ, STOI/ESTOI, latency alignment.

Every function takes 1-D signals (or ``(1, n)`` rows), never mutates them, and floors
every division so silence gives a finite number (or a :class:`MetricError` where the
metric is undefined, e.g. PESQ without an utterance).  See algorithms.md section 8.
"""

from __future__ import annotations

import contextlib
import math
import warnings

import numpy as np

from scenesim.audio import resample
from scenesim.errors import MetricError, ParameterError
from scenesim.validate import check_fs, check_int, check_positive

#: Power floor (per-sample mean square) used in every ratio: about -300 dB re full scale.
POWER_FLOOR = 1e-30
#: PESQ (P.862) needs at least 1/4 s of signal at its own rate.
PESQ_MIN_S = 0.25
#: Peak magnitude below which a signal counts as silent for PESQ/STOI.
SILENCE_PEAK = 1e-10


def _as_1d(x, name: str) -> np.ndarray:
    """``x`` as a float64 1-D array; accepts ``(n,)`` or ``(1, n)``; rejects NaN/Inf."""
    arr = np.asarray(x)
    if arr.dtype.kind not in "fiu":
        raise ParameterError(name, arr, "a real-valued numeric array")
    if arr.ndim == 2 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 1:
        raise ParameterError(name, arr, "a 1-D signal (n_samples,) or a (1, n_samples) row")
    if arr.size == 0:
        raise ParameterError(name, arr, "at least 1 sample")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "finite values only (no NaN or Inf)")
    return arr


def _pair(reference, estimate, names=("reference", "estimate")) -> tuple[np.ndarray, np.ndarray]:
    ref = _as_1d(reference, names[0])
    est = _as_1d(estimate, names[1])
    if ref.shape != est.shape:
        raise ParameterError(names[1], est, f"the same length as {names[0]} ({ref.size} samples)")
    return ref, est


def _power_db_ratio(num: float, den: float) -> float:
    return 10.0 * math.log10(max(num, POWER_FLOOR) / max(den, POWER_FLOOR))


# -- energy ratios -----------------------------------------------------------------------


def snr_db(signal, noise) -> float:
    """Signal-to-noise ratio over the whole signals, in dB.

    ``SNR = 10 log10( sum(signal**2) / sum(noise**2) )``; both mean squares are floored at
    :data:`POWER_FLOOR` so silence gives a large finite number, never NaN/Inf.  Any shape
    (all channels and samples are pooled); both arrays must have the same shape.
    """
    s = np.asarray(signal, dtype=np.float64)
    n = np.asarray(noise, dtype=np.float64)
    if s.shape != n.shape or s.size == 0:
        raise ParameterError("noise", n, f"a non-empty array shaped like signal {s.shape}")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(n))):
        raise ParameterError("signal", s, "finite values only (no NaN or Inf)")
    return _power_db_ratio(float(np.mean(s * s)), float(np.mean(n * n)))


def band_snr_db(signal, noise, *, fs, band_hz) -> float:
    """SNR in dB of ``signal`` over ``noise`` (1-D, same length) within ``band_hz = (lo, hi)``.

    The powers of an ideal (brick-wall) band-pass, by Parseval on a real FFT zero-padded to
    ``scipy.fft.next_fast_len`` (a length like 127,745 samples would cost 10-25x more
    unpadded); padding refines the frequency grid, so the band edges cut a few bins'
    leakage differently than an unpadded FFT (a change of ~1e-3 dB on noise-like signals).
    Mean squares are floored at :data:`POWER_FLOOR` as in :func:`snr_db`.

    >>> t = np.arange(16000) / 16000
    >>> s = np.sin(2 * np.pi * 1000 * t)
    >>> n = 0.1 * np.sin(2 * np.pi * 2000 * t) + np.sin(2 * np.pi * 50 * t)
    >>> round(band_snr_db(s, n, fs=16000, band_hz=(100, 7000)), 1)
    20.0
    """
    from scipy import fft as sfft

    from scenesim.scene.mixing import check_band

    lo, hi = check_band(band_hz, fs=fs)
    s, n = _pair(signal, noise, ("signal", "noise"))
    nfft = sfft.next_fast_len(s.size, real=True)
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    keep = (f >= lo) & (f <= hi)
    # One-sided spectrum: every bin but DC and (even nfft) Nyquist stands for two.
    weight = np.where((f > 0) & (f < fs / 2), 2.0, 1.0)[keep]
    scale = 1.0 / (nfft * s.size)
    p_s = float(np.sum(weight * np.abs(sfft.rfft(s, nfft)[keep]) ** 2)) * scale
    p_n = float(np.sum(weight * np.abs(sfft.rfft(n, nfft)[keep]) ** 2)) * scale
    return _power_db_ratio(p_s, p_n)


def segmental_snr_db(
    reference, estimate, *, fs, frame_s: float = 0.02, clamp: tuple[float, float] = (-10.0, 35.0)
) -> float:
    """Segmental SNR in dB: mean over non-overlapping frames of the clamped frame SNR.

    ``segSNR = mean_m clip( 10 log10( sum_m s^2 / sum_m (s - y)^2 ), lo, hi )``
    (Quackenbush et al. 1988; Hansen & Pellom 1998 clamp -10..35 dB).  Every full frame
    counts, silent ones included (they clamp to ``lo``); a trailing partial frame is dropped.
    Not scale invariant: an enhancer's gain in the look direction shows up here.

    Parameters
    ----------
    reference, estimate : array, shape (n,)
        Clean reference ``s`` and estimate ``y``, time aligned, same length.
    fs : int
        Sampling rate in Hz.
    frame_s : float
        Frame length in seconds (20 ms).
    clamp : (float, float)
        Lower and upper clamp of each frame's SNR in dB.
    """
    ref, est = _pair(reference, estimate)
    fs = check_fs(fs)
    frame_s = check_positive("frame_s", frame_s)
    lo, hi = (float(c) for c in clamp)
    if not lo < hi:
        raise ParameterError("clamp", clamp, "(lo, hi) with lo < hi")
    frame = max(1, int(round(frame_s * fs)))
    n_frames = ref.size // frame
    if n_frames == 0:
        raise MetricError(
            f"segmental SNR needs at least one {frame}-sample frame; got {ref.size} samples"
        )
    s = ref[: n_frames * frame].reshape(n_frames, frame)
    e = s - est[: n_frames * frame].reshape(n_frames, frame)
    num = np.maximum(np.mean(s * s, axis=1), POWER_FLOOR)
    den = np.maximum(np.mean(e * e, axis=1), POWER_FLOOR)
    return float(np.mean(np.clip(10.0 * np.log10(num / den), lo, hi)))


def si_sdr_db(reference, estimate) -> float:
    """Scale-invariant signal-to-distortion ratio in dB (Le Roux et al. 2019, eq. 3-4).

    Both signals are made zero-mean; ``alpha = <y, s> / ||s||^2``,
    ``SI-SDR = 10 log10( ||alpha s||^2 / ||alpha s - y||^2 )`` (floored).
    """
    ref, est = _pair(reference, estimate)
    ref = ref - ref.mean()
    est = est - est.mean()
    # numpy's pairwise sums, not BLAS dot: a threaded ddot splits long sums by the thread count,
    # so a worker process and its parent disagreed in the last bits (scenesim score --workers).
    alpha = float(np.sum(est * ref)) / max(float(np.sum(ref * ref)), POWER_FLOOR)
    target = alpha * ref
    resid = est - target
    return _power_db_ratio(float(np.sum(target * target)), float(np.sum(resid * resid)))


# -- perceptual metrics ------------------------------------------------------------------


def _check_not_silent(x: np.ndarray, name: str, metric: str) -> None:
    if float(np.max(np.abs(x))) < SILENCE_PEAK:
        raise MetricError(f"{metric}: the {name} signal is silent")


def _pesq_one(fs: int, ref: np.ndarray, deg: np.ndarray, mode: str) -> float:
    import pesq as pesq_pkg

    try:
        return float(pesq_pkg.pesq(fs, ref, deg, mode))
    except (pesq_pkg.PesqError, ValueError, RuntimeError) as exc:
        reason = exc.args[0] if exc.args else str(exc)
        if isinstance(reason, bytes):
            reason = reason.decode(errors="replace")
        raise MetricError(f"PESQ ({mode}) failed: {type(exc).__name__}: {reason}") from None


def pesq_scores(reference, degraded, *, fs) -> dict[str, float | None]:
    """Narrow-band (ITU-T P.862) and wide-band (P.862.2) PESQ MOS-LQO via the ``pesq`` package.

    At ``fs = 16000`` both modes run on the signals as given (the ``pesq`` package's own
    oracle: its README pair scores wb 1.0832337141036987, nb 1.6072081327438354).  Other
    rates are resampled (``scipy.signal.resample_poly``): to 16 kHz when ``fs > 16000``,
    to 8 kHz when ``fs < 16000`` -- and then ``"wb"`` is ``None``: wide-band PESQ of a
    signal with no content above 4 kHz is not meaningful.  For the same reason a 16 kHz
    reference that is narrow-band (:func:`is_narrowband`, e.g. upsampled from 8 kHz) gets
    its ``"wb"`` labelled by a :class:`NarrowbandWarning`.

    Parameters
    ----------
    reference, degraded : array, shape (n,)
        Clean reference and processed signal, time aligned, same length.
    fs : int
        Sampling rate in Hz.

    Returns
    -------
    dict
        ``{"nb": float, "wb": float or None}``.

    Raises
    ------
    MetricError
        Silent input, less than 0.25 s, or a PESQ failure (``NoUtterancesError`` ...);
        the message gives the reason.
    """
    ref, deg = _pair(reference, degraded, ("reference", "degraded"))
    fs = check_fs(fs)
    _check_not_silent(ref, "reference", "PESQ")
    _check_not_silent(deg, "degraded", "PESQ")
    if ref.size < PESQ_MIN_S * fs:
        raise MetricError(
            f"PESQ needs at least {PESQ_MIN_S} s of signal; got {ref.size / fs:.3f} s"
        )
    fs_pesq = 16000 if fs >= 16000 else 8000
    ref = resample(ref, fs, fs_pesq)  # the one resampling wrapper (scenesim.audio)
    deg = resample(deg, fs, fs_pesq)
    nb = _pesq_one(fs_pesq, ref, deg, "nb")
    wb = None
    if fs_pesq == 16000:
        wb = _pesq_one(fs_pesq, ref, deg, "wb")
        if _is_narrowband_cached(ref, fs_pesq):  # labelled, not refused: the caller decides
            warnings.warn(
                f"wide-band PESQ {wb:.2f} is of a narrow-band reference (energy above 4.5 kHz "
                f"below {WIDEBAND_MIN_DB:g} dB; upsampled from 8 kHz?): P.862.2 then scores the "
                "missing band, not the processing; use the narrow-band score",
                NarrowbandWarning,
                stacklevel=2,
            )
    return {"nb": nb, "wb": wb}


#: ITU-T P.862.1 mapping constants: MOS-LQO = 0.999 + 4 / (1 + exp(-1.4945 x + 4.6607)).
P8621_SLOPE = 1.4945
P8621_OFFSET = 4.6607
#: Range of raw P.862 scores (the scale the thesis' text describes).
P862_RAW_RANGE = (-0.5, 4.5)


def pesq_raw_from_mos_lqo(mos_lqo: float) -> float:
    """Raw ITU-T P.862 score from the ``pesq`` package's narrow-band MOS-LQO (P.862.1 inverted).

    The package's ``"nb"`` score is ``y = 0.999 + 4 / (1 + exp(-1.4945 x + 4.6607))`` of the
    raw P.862 score ``x`` (algorithms.md 4b), so
    ``x = (4.6607 - ln(4 / (y - 0.999) - 1)) / 1.4945``, clipped to the raw range
    [-0.5, 4.5] (the mapping's ends, MOS-LQO 1.016..4.549, are where it saturates).

    >>> round(pesq_raw_from_mos_lqo(0.999 + 4 / (1 + np.exp(-1.4945 * 3.0 + 4.6607))), 9)
    3.0
    """
    y = float(mos_lqo)
    if not math.isfinite(y):
        raise ParameterError("mos_lqo", mos_lqo, "a finite MOS-LQO score")
    lo, hi = P862_RAW_RANGE
    if y <= 0.999 + 4.0 / (1.0 + math.exp(-P8621_SLOPE * lo + P8621_OFFSET)):
        return lo
    if y >= 0.999 + 4.0 / (1.0 + math.exp(-P8621_SLOPE * hi + P8621_OFFSET)):
        return hi
    return (P8621_OFFSET - math.log(4.0 / (y - 0.999) - 1.0)) / P8621_SLOPE


class NarrowbandWarning(UserWarning):
    """Wide-band PESQ was computed on a reference with no content above 4.5 kHz."""


WIDEBAND_MIN_DB = -45.0
"""Energy above 4.5 kHz (dB re the total) below which a 16 kHz signal counts as narrow-band.

Measured (Welch, 512-point segments): real and artificial wide-band speech -12.5 to
-27.4 dB (CMU ARCTIC, the built-in voice); the same upsampled from 8 kHz -59.8 to
-68.8 dB (with sensor noise 60 dB down included)."""


def is_narrowband(x, fs: int) -> bool:
    """True if ``x`` (``(n,)``, 16 kHz or more) has under :data:`WIDEBAND_MIN_DB` of its energy above 4.5 kHz."""
    from scipy.signal import welch

    f, p = welch(np.asarray(x, dtype=float), fs=fs, nperseg=min(512, np.size(x)))
    total = float(p.sum())
    return total > 0 and 10.0 * np.log10(max(float(p[f > 4500.0].sum()), 1e-300) / total) < WIDEBAND_MIN_DB


_NARROWBAND_SEEN: dict[tuple, bool] = {}
_NARROWBAND_ITEMS = 16


def _is_narrowband_cached(x: np.ndarray, fs: int) -> bool:
    """:func:`is_narrowband` memoised on the signal's bytes: a sweep scores every system's
    output against the same reference, whose Welch PSD need not be recomputed per call."""
    key = (int(fs), x.size, hash(np.ascontiguousarray(x, dtype=np.float64).tobytes()))
    if key not in _NARROWBAND_SEEN:
        if len(_NARROWBAND_SEEN) >= _NARROWBAND_ITEMS:
            _NARROWBAND_SEEN.pop(next(iter(_NARROWBAND_SEEN)))  # oldest first
        _NARROWBAND_SEEN[key] = is_narrowband(x, fs)
    return _NARROWBAND_SEEN[key]


@contextlib.contextmanager
def _seeded_global_rng(seed: int):
    """Seed numpy's global RNG within the block and restore the caller's state after it.

    pystoi's extended STOI adds ``EPS * np.random.standard_normal`` dither to its
    normalised frames; unseeded, ESTOI of a noisy reference varied by ~5e-4 from call to
    call (measured on the pair in tests/test_metric_pins.py).
    """
    # Legacy global-RNG calls on purpose: that global RNG is what pystoi draws from.
    state = np.random.get_state()  # noqa: NPY002
    np.random.seed(seed)  # noqa: NPY002
    try:
        yield
    finally:
        np.random.set_state(state)  # noqa: NPY002


def stoi_scores(reference, degraded, *, fs) -> dict[str, float]:
    """STOI (Taal et al. 2011) and extended STOI (Jensen & Taal 2016), pystoi's algorithm.

    Both in one pass (:func:`benchmarks.metrics.stoi_pair.stoi_estoi`: pystoi's resampling to 10 kHz,
    removal of frames 40 dB below the loudest and STFTs done once; the scores equal
    ``pystoi.stoi(..., extended=False/True)`` to rounding).  When fewer than 30 frames
    (about 0.4 s of active speech) remain, ``pystoi`` would return 1e-5 with a warning; this
    raises :class:`MetricError` instead, as it does for silence.

    Returns
    -------
    dict
        ``{"stoi": float, "estoi": float}`` (0..1, higher is better).
    """
    from benchmarks.metrics.stoi_pair import stoi_estoi

    ref, deg = _pair(reference, degraded, ("reference", "degraded"))
    fs = check_fs(fs)
    _check_not_silent(ref, "reference", "STOI")
    with warnings.catch_warnings(), _seeded_global_rng(0):
        warnings.simplefilter("ignore")  # as before: pystoi's numerical warnings never reach the row
        scores = stoi_estoi(ref, deg, fs)
    if scores is None:
        raise MetricError("STOI: too little active speech (< 30 frames)")
    out = {}
    for key, value in zip(("stoi", "estoi"), scores):
        if not math.isfinite(value):
            raise MetricError(f"{key.upper()}: not finite ({value})")
        out[key] = value
    return out


# -- alignment ---------------------------------------------------------------------------


def align(output, reference, *, latency_samples) -> tuple[np.ndarray, np.ndarray]:
    """Undo an enhancer's declared latency so ``out_aligned[n] = output[n + latency]``
    pairs with ``ref_aligned[n] = reference[n]``; both trimmed to the common length.

    Works on the last axis of 1-D or 2-D arrays (channels kept).  Returns views.
    """
    latency = check_int("latency_samples", latency_samples, minimum=0)
    out = np.asarray(output)
    ref = np.asarray(reference)
    n = min(out.shape[-1] - latency, ref.shape[-1])
    if n <= 0:
        raise ParameterError(
            "latency_samples", latency, f"fewer than the output's {out.shape[-1]} samples"
        )
    return out[..., latency : latency + n], ref[..., :n]


def estimate_lag(a, b, *, max_lag) -> int:
    """Lag ``L`` (samples, ``|L| <= max_lag``) maximising ``|sum_n a[n + L] b[n]|``.

    Positive ``L`` means ``a`` is a delayed copy of ``b``.  The cross-correlation is
    computed with one zero-padded real FFT (no circular wrap-around); the absolute value
    makes a polarity inversion irrelevant.  Ties go to the smallest ``|L|``.
    """
    a = _as_1d(a, "a")
    b = _as_1d(b, "b")
    max_lag = check_int("max_lag", max_lag, minimum=0)
    from scipy import fft as sfft

    # Lags up to max_lag only: a circular correlation of length >= max(size) + max_lag has no
    # wrap-around at them (a fast length, not the full 2n power of two: 2-3x less work).
    nfft = sfft.next_fast_len(max(a.size, b.size) + min(max_lag, max(a.size, b.size)) + 1, real=True)
    corr = sfft.irfft(sfft.rfft(a, nfft) * np.conj(sfft.rfft(b, nfft)), nfft)
    # corr[k] = sum_n a[n + k] b[n]; negative lags wrap to the end of the buffer.
    lags = np.arange(-max_lag, max_lag + 1)
    lags = lags[(lags < a.size) & (lags > -b.size)]
    values = np.abs(corr[lags % nfft])
    best = np.flatnonzero(values >= values.max() * (1 - 1e-12))
    return int(lags[best[np.argmin(np.abs(lags[best]))]])
