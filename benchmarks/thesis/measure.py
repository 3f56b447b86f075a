"""Three ways to measure an enhancer's output SNR, one of the thesis' lost details.

The thesis' eq. 7.1 defines the SNR by whole-signal powers but not how the output's speech and noise
were told apart.  Three readings, each ``10 log10(P_speech / P_noise)`` with ``P`` a mean square:

``replay``
    The recorded operation applied to the speech and the noise apart (algorithms.md section 8):
    ``SNR_out = P(f_t(s)) / P(f_t(n))``.  Exact for a linear time-varying enhancer.
``y-s``
    The output minus the clean speech at the reference mic, aligned by the declared latency ``L``:
    ``SNR_out = P(s_ref) / P(y - s_ref)`` with ``y[k + L]`` paired with ``s_ref[k]``.  Everything
    that is not the unprocessed talker counts as noise, speech distortion included, so the SNR
    saturates at the distortion's level.
``hagerman``
    Phase inversion (Hagerman and Olofsson 2004): ``y1 = f(s + n)``, ``y2 = f(s - n)``,
    ``SNR_out = P((y1 + y2) / 2) / P((y1 - y2) / 2)`` over the aligned samples.

>>> s, n = np.array([1.0, -1.0, 1.0, -1.0]), np.array([0.5, 0.5, -0.5, -0.5])
>>> round(snr_y_minus_s_db(2.0 * (s + n), s, latency=0), 6)  # P(s) / P(s + 2n) = 1 / 2
-3.0103
"""

from __future__ import annotations

import numpy as np

MEASURES = ("replay", "y-s", "hagerman")
"""The output-SNR measurements searched (see the module docstring)."""


def snr_db(s: np.ndarray, n: np.ndarray) -> float:
    """``10 log10(mean(s^2) / mean(n^2))`` (whole-signal powers, eq. 7.1); the noise power floored at 1e-300."""
    return float(10 * np.log10(np.mean(s * s) / max(float(np.mean(n * n)), 1e-300)))


def _aligned(y: np.ndarray, ref: np.ndarray, latency: int) -> tuple[np.ndarray, np.ndarray]:
    from benchmarks.metrics.speech import align

    return align(y, ref, latency_samples=int(latency))


def snr_y_minus_s_db(y: np.ndarray, s_ref: np.ndarray, *, latency: int) -> float:
    """``P(s_ref) / P(y - s_ref)`` in dB, ``y`` (``(n_samples,)``) delayed by ``latency`` samples."""
    y_al, s_al = _aligned(y, s_ref, latency)
    return snr_db(s_al, y_al - s_al)


def snr_hagerman_db(y1: np.ndarray, y2: np.ndarray, *, latency: int) -> float:
    """Phase-inversion output SNR from ``y1 = f(s + n)`` and ``y2 = f(s - n)`` (``(n_samples,)`` each)."""
    y1_al, y2_al = y1[int(latency):], y2[int(latency):]  # both outputs lag alike: trim the same samples
    return snr_db(0.5 * (y1_al + y2_al), 0.5 * (y1_al - y2_al))


def output_snrs(*, ys: np.ndarray, yn: np.ndarray, y: np.ndarray, y2: np.ndarray | None,
                s_ref: np.ndarray, latency: int) -> dict[str, float]:
    """Output SNR (dB) by every measurement: ``ys``, ``yn`` the replayed speech and noise, ``y`` the
    output of ``s + n``, ``y2`` that of ``s - n`` (None: no Hagerman), ``s_ref`` the clean speech at
    the reference mic; all ``(n_samples,)``.

    >>> s, n = np.ones(8), np.array([1.0, -1.0] * 4)
    >>> out = output_snrs(ys=s, yn=0.1 * n, y=s + 0.1 * n, y2=s - 0.1 * n, s_ref=s, latency=0)
    >>> [round(v, 6) for v in out.values()]
    [20.0, 20.0, 20.0]
    """
    out = {"replay": snr_db(ys, yn), "y-s": snr_y_minus_s_db(y, s_ref, latency=latency)}
    if y2 is not None:
        out["hagerman"] = snr_hagerman_db(y, y2, latency=latency)
    return out
