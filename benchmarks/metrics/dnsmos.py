"""DNSMOS P.835 (Reddy et al. 2022): non-intrusive SIG, BAK and OVRL scores of 16 kHz speech.

DNSMOS is a neural network trained on human P.835 ratings of 16 kHz noisy and processed
speech: it needs no clean reference, so it scores real recordings too.  ``dnsmos_sig`` rates
the speech signal's distortion, ``dnsmos_bak`` the intrusiveness of the background noise,
``dnsmos_ovrl`` the overall quality, each on a 1-5 MOS scale.  It was trained on 16 kHz
audio only; other rates must be resampled first (:func:`benchmarks.metrics.scoring.score` does).

Optional: ``pip install -e '.[dnsmos]'`` (``speechmos``, MIT, published by the organisers of
Microsoft's DNS and AEC challenges, whose wheel holds the ONNX models; ``onnxruntime``, MIT).
Nothing is downloaded at run time.

Only ``speechmos``'s model files ``dnsmos_models/sig_bak_ovr.onnx`` (P.835) and
``dnsmos_models/model_v8.onnx`` (P.808) are used: its ``speechmos.dnsmos.run`` computes the
P.808 features through ``librosa`` (which ``speechmos`` does not declare) and opens a new
pair of ONNX sessions with every core's threads.  Here each session is opened once per process
with one intra-op thread, the P.808 log-mel features are computed in numpy
(:func:`p808_features`, equal to ``librosa.feature.melspectrogram`` + ``power_to_db``), and the
clip procedure is ``speechmos``' own (checked against it in tests/test_dnsmos.py):

1. a clip shorter than 9.01 s is repeated (concatenated with itself) until it is not;
2. windows of 9.01 s hop by 1 s; ``floor(len / fs - 9.01) + 1`` of them;
3. each window's raw (SIG, BAK, OVRL) from the network goes through the non-personalised
   second-order polynomial calibration and the scores are averaged over windows;
4. P.808: the window less its last 10 ms gives 900 frames of 120 log-mel bands (321-point
   periodic Hann, hop 160, zero-padded centring, Slaney mel scale and area normalisation,
   ``10 log10`` re the window's maximum floored 80 dB below it, then ``(dB + 40) / 40``);
   the network's score is averaged over windows, with no calibration.

Without the extra, :func:`dnsmos_p835` and :func:`dnsmos_p808` raise
:class:`scenesim.errors.ExtraNotInstalled` naming ``pip install "scenesim[dnsmos]"``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from benchmarks.metrics.speech import _check_not_silent
from scenesim.errors import ExtraNotInstalled, MetricError, ParameterError

__all__ = ["COLUMNS", "FS", "dnsmos_p808", "dnsmos_p835", "input_columns", "installed", "model_digests",
           "output_columns", "p808_features", "require"]

FS = 16000
"""The only rate DNSMOS accepts (Hz)."""
_WINDOW_S = 9.01
# Non-personalised calibration polynomials (highest power first), as in speechmos 0.0.1.1.
_POLY = {
    "dnsmos_sig": (-0.08397278, 1.22083953, 0.0052439),
    "dnsmos_bak": (-0.13166888, 1.60915514, -0.39604546),
    "dnsmos_ovrl": (-0.06766283, 1.11546468, 0.04602535),
}


# P.808 features (speechmos' audio_melspec): 321-point frames, hop 160, 120 Slaney mel bands.
_P808_NFFT, _P808_HOP, _P808_MELS = 321, 160, 120


def installed() -> bool:
    """True when the ``[dnsmos]`` extra (``speechmos`` and ``onnxruntime``) can be imported."""
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in ("speechmos", "onnxruntime"))


def require() -> None:
    """Raise :class:`~scenesim.errors.ExtraNotInstalled` (the ``pip install`` line) without the extra."""
    if not installed():
        raise ExtraNotInstalled("dnsmos", "DNSMOS")


@functools.lru_cache(maxsize=2)
def _session(model_file: str = "sig_bak_ovr.onnx"):
    """An ONNX session of one speechmos model: opened once per process, one intra-op thread
    (workers are processes)."""
    import importlib.resources

    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    model = importlib.resources.files("speechmos") / "dnsmos_models" / model_file
    return ort.InferenceSession(str(model), sess_options=options, providers=["CPUExecutionProvider"])


def model_digests() -> dict[str, str]:
    """SHA-256 of the two speechmos model files used (the versions sidecar of ``scenesim score``)."""
    import hashlib
    import importlib.resources

    require()
    folder = importlib.resources.files("speechmos") / "dnsmos_models"
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest()
            for name in ("sig_bak_ovr.onnx", "model_v8.onnx")}


def _hz_to_mel(f: np.ndarray) -> np.ndarray:
    """Slaney's mel scale (librosa ``htk=False``): linear below 1 kHz, logarithmic above."""
    f = np.asarray(f, dtype=np.float64)
    lin = f / (200.0 / 3)
    return np.where(f >= 1000.0, 15.0 + np.log(np.maximum(f, 1e-10) / 1000.0) / (np.log(6.4) / 27.0), lin)


def _mel_to_hz(m: np.ndarray) -> np.ndarray:
    m = np.asarray(m, dtype=np.float64)
    return np.where(m >= 15.0, 1000.0 * np.exp((np.log(6.4) / 27.0) * (m - 15.0)), (200.0 / 3) * m)


@functools.lru_cache(maxsize=1)
def _mel_basis() -> np.ndarray:
    """``(120, 161)`` triangular Slaney-normalised mel filters over 0..8 kHz (librosa.filters.mel)."""
    freqs = np.fft.rfftfreq(_P808_NFFT, 1.0 / FS)
    edges = _mel_to_hz(np.linspace(_hz_to_mel(0.0), _hz_to_mel(FS / 2.0), _P808_MELS + 2))
    width = np.diff(edges)
    ramps = edges[:, None] - freqs[None, :]
    lower = -ramps[:-2] / width[:-1, None]
    upper = ramps[2:] / width[1:, None]
    weights = np.maximum(0.0, np.minimum(lower, upper)) * (2.0 / (edges[2:] - edges[:-2]))[:, None]
    return weights.astype(np.float32)  # librosa's default dtype


def p808_features(window: np.ndarray) -> np.ndarray:
    """``(900, 120)`` float32 log-mel features of one 9.01 s window (step 4 of the module docstring).

    >>> p808_features(np.ones(144160)).shape
    (900, 120)
    """
    y = np.asarray(window, dtype=np.float64)[:-_P808_HOP]
    pad = _P808_NFFT // 2
    frames = np.lib.stride_tricks.sliding_window_view(np.pad(y, pad), _P808_NFFT)[::_P808_HOP]
    hann = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(_P808_NFFT) / _P808_NFFT)  # periodic
    power = np.abs(np.fft.rfft(frames * hann, axis=-1)) ** 2
    mel = power @ _mel_basis().T.astype(np.float64)
    db = 10.0 * np.log10(np.maximum(mel, 1e-10)) - 10.0 * np.log10(max(float(mel.max()), 1e-10))
    db = np.maximum(db, db.max() - 80.0)
    return ((db + 40.0) / 40.0).astype(np.float32)


def _windows(x: np.ndarray) -> np.ndarray:
    """``(n_windows, 9.01 s)`` float32 windows, hop 1 s, of ``x`` repeated to at least 9.01 s."""
    n_win = int(_WINDOW_S * FS)
    while x.size < n_win:
        x = np.concatenate([x, x])
    n_hops = int(math.floor(x.size / FS) - _WINDOW_S) + 1
    return np.stack([x[i * FS: i * FS + n_win] for i in range(n_hops)]).astype(np.float32)


def dnsmos_p835(x, fs: int) -> dict[str, float]:
    """DNSMOS P.835 scores of a mono 16 kHz signal.

    Parameters
    ----------
    x : array (n,)
        Speech (any length above 0; short clips are repeated), full-scale float in [-1, 1].
    fs : int
        Must be 16000.

    Returns
    -------
    dict
        ``{"dnsmos_sig": float, "dnsmos_bak": float, "dnsmos_ovrl": float}`` (MOS, about 1..5).

    Example
    -------
    >>> import numpy as np
    >>> noise = 0.1 * np.random.default_rng(0).standard_normal(16000)
    >>> scores = dnsmos_p835(noise, 16000)
    >>> sorted(scores), bool(scores["dnsmos_bak"] < 3)
    (['dnsmos_bak', 'dnsmos_ovrl', 'dnsmos_sig'], True)
    """
    x = _checked(x, fs)
    session = _session()
    raw = np.array([session.run(None, {"input_1": w[None]})[0][0] for w in _windows(x)])
    return {key: float(np.mean(np.polyval(_POLY[key], raw[:, i]))) for i, key in enumerate(_POLY)}


def _checked(x, fs: int) -> np.ndarray:
    require()
    if int(fs) != FS:
        raise ParameterError("fs", fs, f"{FS} (DNSMOS was trained on 16 kHz speech: resample first)")
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise ParameterError("x", x, "a finite, non-empty mono signal (n,)")
    if np.max(np.abs(x)) > 1.0:
        raise MetricError("DNSMOS: samples beyond full scale (|x| > 1); scale the signal down")
    _check_not_silent(x, "scored", "DNSMOS")  # the network rates silence ~1.8: undefined, not a score
    return x


def dnsmos_p808(x, fs: int) -> float:
    """DNSMOS P.808 overall quality (1-5 MOS) of a mono 16 kHz signal ``(n,)`` (steps 1, 2, 4).

    Example
    -------
    >>> import numpy as np
    >>> noise = 0.1 * np.random.default_rng(0).standard_normal(16000)
    >>> bool(1.0 < dnsmos_p808(noise, 16000) < 3.0)
    True
    """
    x = _checked(x, fs)
    session = _session("model_v8.onnx")
    scores = [session.run(None, {"input_1": p808_features(w)[None]})[0][0][0] for w in _windows(x)]
    return float(np.mean(scores))


# -- results-store columns (a sweep opts in with metrics = ["dnsmos"]) ----------------------

#: Store columns: the mixture at the reference mic (``*_in``) and the first output channel.
COLUMNS: dict[str, str] = {f"{k}{suffix}": "REAL" for suffix in ("_in", "") for k in _POLY}


def _scores_at_16k(x: np.ndarray, fs: int) -> dict[str, float]:
    from scenesim.audio import resample

    x = np.asarray(x, dtype=np.float64)
    return dnsmos_p835(x if int(fs) == FS else resample(x[None], int(fs), FS)[0], FS)


def input_columns(mixture0, fs: int) -> dict[str, float]:
    """``dnsmos_sig_in``, ``dnsmos_bak_in``, ``dnsmos_ovrl_in`` of the mixture at the reference mic ``(n,)``."""
    return {f"{k}_in": v for k, v in _scores_at_16k(mixture0, fs).items()}


def output_columns(output0, fs: int, latency_samples: int) -> dict[str, float]:
    """``dnsmos_sig``, ``dnsmos_bak``, ``dnsmos_ovrl`` of an output channel ``(n,)`` after its latency."""
    return _scores_at_16k(np.asarray(output0)[int(latency_samples):], fs)
