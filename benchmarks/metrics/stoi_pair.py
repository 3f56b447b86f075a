"""STOI and extended STOI of one signal pair in one pass (pystoi's algorithm, steps shared).

``pystoi.stoi(x, y, fs, extended=False)`` and ``extended=True`` repeat the same first steps:
resampling to 10 kHz, removal of the frames 40 dB below the loudest clean frame, the
256-sample STFTs and the one-third-octave band envelopes.  :func:`stoi_estoi` runs them once
and then both final steps, with pystoi's own helpers and constants (``pystoi.utils``) and
vectorised framing (a batched FFT instead of a Python loop, diagonal scalings as
broadcasting instead of ``matmul`` with ``diag`` matrices: the same products, so the same
numbers to rounding; the test pins both scores to pystoi's within 1e-9).

ESTOI draws pystoi's ``EPS``-scaled dither from numpy's global RNG, as pystoi does: the
caller seeds it (:func:`benchmarks.metrics.speech.stoi_scores` seeds 0, as before).
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view


def _pystoi_module():
    """The module ``pystoi.stoi`` (its constants); ``pystoi.stoi`` as an attribute is the function."""
    import importlib

    return importlib.import_module("pystoi.stoi")


#: pystoi's fewest frames for the intermediate intelligibility measure (its ``N``).
MIN_FRAMES = 30


def _frames(x: np.ndarray, size: int, hop: int) -> np.ndarray:
    """pystoi's framing ``[x[i:i + size] for i in range(0, len(x) - size, hop)]`` as a view."""
    n = len(range(0, len(x) - size, hop))
    return sliding_window_view(x, size)[: (n - 1) * hop + 1 : hop] if n > 0 else np.empty((0, size))


def _remove_silent_frames(x, y, dyn_range: float, framelen: int, hop: int):
    """``pystoi.utils.remove_silent_frames`` with vectorised framing (same arithmetic)."""
    from pystoi import utils

    w = np.hanning(framelen + 2)[1:-1]
    x_frames = w * _frames(x, framelen, hop)
    y_frames = w * _frames(y, framelen, hop)
    x_energies = 20 * np.log10(np.linalg.norm(x_frames, axis=1) + utils.EPS)
    mask = (np.max(x_energies) - dyn_range - x_energies) < 0
    return utils._overlap_and_add(x_frames[mask], hop), utils._overlap_and_add(y_frames[mask], hop)


def _band_envelopes(x: np.ndarray) -> np.ndarray:
    """One-third-octave band magnitudes ``(15, n_frames)`` of ``x`` at 10 kHz (pystoi eq. 1)."""
    S = _pystoi_module()

    w = np.hanning(S.N_FRAME + 2)[1:-1]
    spec = np.fft.rfft(w * _frames(x, S.N_FRAME, S.N_FRAME // 2), n=S.NFFT, axis=-1).T
    return np.sqrt(np.matmul(S.OBM, np.square(np.abs(spec))))


def _row_col_normalize(x: np.ndarray) -> np.ndarray:
    """``pystoi.utils.row_col_normalize`` with the diagonal matmuls as broadcasting."""
    from pystoi import utils

    x_normed = x + utils.EPS * np.random.standard_normal(x.shape)  # noqa: NPY002 (pystoi's draw)
    x_normed -= np.mean(x_normed, axis=-1, keepdims=True)
    x_normed = x_normed * (1.0 / np.sqrt(utils.vect_two_norm(x_normed)))
    x_normed += +utils.EPS * np.random.standard_normal(x_normed.shape)  # noqa: NPY002
    x_normed -= np.mean(x_normed, axis=1, keepdims=True)
    return x_normed * (1.0 / np.sqrt(utils.vect_two_norm(x_normed, axis=1)))


def _stoi_final(x_seg: np.ndarray, y_seg: np.ndarray) -> float:
    """pystoi's classic STOI from the segments ``(J, 15, 30)`` (normalise, clip, correlate)."""
    S = _pystoi_module()
    from pystoi import utils

    norm = np.linalg.norm(x_seg, axis=2, keepdims=True) / (np.linalg.norm(y_seg, axis=2, keepdims=True) + utils.EPS)
    y_primes = np.minimum(y_seg * norm, x_seg * (1 + 10 ** (-S.BETA / 20)))
    y_primes = y_primes - np.mean(y_primes, axis=2, keepdims=True)
    x_seg = x_seg - np.mean(x_seg, axis=2, keepdims=True)
    y_primes /= np.linalg.norm(y_primes, axis=2, keepdims=True) + utils.EPS
    x_seg /= np.linalg.norm(x_seg, axis=2, keepdims=True) + utils.EPS
    return float(np.sum(y_primes * x_seg) / (x_seg.shape[0] * x_seg.shape[1]))


def stoi_estoi(x, y, fs: int) -> tuple[float, float] | None:
    """``(stoi, estoi)`` of clean ``x`` and processed ``y`` (1-D, same length, ``fs`` Hz).

    ``None`` when fewer than 30 frames survive silent-frame removal (where pystoi warns and
    returns 1e-5).  ESTOI's dither comes from numpy's global RNG (seed it for repeatability).

    >>> rng = np.random.default_rng(0)
    >>> x = rng.standard_normal(16000) * np.repeat(rng.uniform(0.1, 1, 50), 320)
    >>> s, e = stoi_estoi(x, x, 16000)
    >>> round(s, 6), round(e, 6)
    (1.0, 1.0)
    """
    S = _pystoi_module()
    from pystoi import utils

    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if fs != S.FS:
        x = utils.resample_oct(x, S.FS, fs)
        y = utils.resample_oct(y, S.FS, fs)
    if x.size < S.N_FRAME:  # not one frame: nothing to compare (pystoi fails on the empty max)
        return None
    x, y = _remove_silent_frames(x, y, S.DYN_RANGE, S.N_FRAME, S.N_FRAME // 2)
    x_tob, y_tob = _band_envelopes(x), _band_envelopes(y)
    if x_tob.shape[-1] < MIN_FRAMES:
        return None
    # Segments of N frames ending at m = N .. n_frames: shape (J, 15, N), as pystoi builds them.
    x_seg = np.ascontiguousarray(sliding_window_view(x_tob, S.N, axis=1).transpose(1, 0, 2))
    y_seg = np.ascontiguousarray(sliding_window_view(y_tob, S.N, axis=1).transpose(1, 0, 2))
    classic = _stoi_final(x_seg, y_seg)
    x_n, y_n = _row_col_normalize(x_seg), _row_col_normalize(y_seg)
    return classic, float(np.sum(x_n * y_n / S.N) / x_n.shape[0])
