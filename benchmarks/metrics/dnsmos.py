"""DNSMOS P.835 (Reddy et al. 2022): non-intrusive SIG, BAK and OVRL scores of 16 kHz speech.

DNSMOS is a neural network trained on human P.835 ratings of 16 kHz noisy and processed
speech: it needs no clean reference, so it scores real recordings too.  ``dnsmos_sig`` rates
the speech signal's distortion, ``dnsmos_bak`` the intrusiveness of the background noise,
``dnsmos_ovrl`` the overall quality, each on a 1-5 MOS scale.  It was trained on 16 kHz
audio only; other rates must be resampled first (:func:`benchmarks.metrics.scoring.score` does).

Optional: ``pip install -e '.[dnsmos]'`` (``speechmos``, MIT, published by the organisers of
Microsoft's DNS and AEC challenges, whose wheel holds the ONNX models; ``onnxruntime``, MIT).
Nothing is downloaded at run time.

Only ``speechmos``'s model file ``dnsmos_models/sig_bak_ovr.onnx`` is used: its
``speechmos.dnsmos.run`` also computes the P.808 score through ``librosa`` (which
``speechmos`` does not declare) and opens a new pair of ONNX sessions with every core's
threads.  Here the session is opened once per process with one intra-op thread, and the
clip procedure is ``speechmos``' own (checked against it in tests/test_dnsmos.py):

1. a clip shorter than 9.01 s is repeated (concatenated with itself) until it is not;
2. windows of 9.01 s hop by 1 s; ``floor(len / fs - 9.01) + 1`` of them;
3. each window's raw (SIG, BAK, OVRL) from the network goes through the non-personalised
   second-order polynomial calibration and the scores are averaged over windows.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenesim.errors import MetricError, ParameterError

__all__ = ["COLUMNS", "FS", "dnsmos_p835", "input_columns", "output_columns"]

FS = 16000
"""The only rate DNSMOS accepts (Hz)."""
_WINDOW_S = 9.01
# Non-personalised calibration polynomials (highest power first), as in speechmos 0.0.1.1.
_POLY = {
    "dnsmos_sig": (-0.08397278, 1.22083953, 0.0052439),
    "dnsmos_bak": (-0.13166888, 1.60915514, -0.39604546),
    "dnsmos_ovrl": (-0.06766283, 1.11546468, 0.04602535),
}


@functools.lru_cache(maxsize=1)
def _session():
    """The P.835 ONNX session: opened once per process, one intra-op thread (workers are processes)."""
    import importlib.resources

    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    model = importlib.resources.files("speechmos") / "dnsmos_models" / "sig_bak_ovr.onnx"
    return ort.InferenceSession(str(model), sess_options=options, providers=["CPUExecutionProvider"])


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
    if int(fs) != FS:
        raise ParameterError("fs", fs, f"{FS} (DNSMOS was trained on 16 kHz speech: resample first)")
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise ParameterError("x", x, "a finite, non-empty mono signal (n,)")
    if np.max(np.abs(x)) > 1.0:
        raise MetricError("DNSMOS: samples beyond full scale (|x| > 1); scale the signal down")
    session = _session()
    raw = np.array([session.run(None, {"input_1": w[None]})[0][0] for w in _windows(x)])
    return {key: float(np.mean(np.polyval(_POLY[key], raw[:, i]))) for i, key in enumerate(_POLY)}


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
