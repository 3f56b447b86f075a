"""What an adaptive system's two Hagerman runs say about its own stability on the talker.

Hagerman & Olofsson's phase inversion processes ``s + n`` (the system adapts to operation
``W1``) and ``s - n`` (it adapts to ``W2``).  For a white box both operations can be replayed
on each component, which gives four signals of shape ``(n_out, n_samples)`` (or ``(n,)``):
``W1 s``, ``W2 s``, ``W1 n``, ``W2 n`` -- all with ``+n``, the sign lives in the mixture only.

* :func:`speech_jitter_db` -- ``P((W1 - W2) s) / P(W1 s)``: how much the talker's path moves
  when only the noise's sign changes.  Where the adaptation learns from noise-only cells (the
  two mixtures have the same second-order statistics there) ``W1 = W2`` and the jitter is
  ``-inf``; a system that listens to the talker while adapting shows it here.
* :func:`hagerman_leak_db` -- Hagerman's noise estimate ``(y1 - y2) / 2`` is
  ``(W1 + W2) n / 2 + (W1 - W2) s / 2``: the second term is speech leaking into the noise
  measure.  Its power re the first term's; above 0 dB the row's Hagerman SNR-I measures the
  leak, not the noise.

Both are ratios of powers of signals from the same run, so the common latency cancels: no
alignment is needed.  Powers are means over every channel and sample.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hagerman_leak_db", "speech_jitter_db"]


def _power(x) -> float:
    return float(np.mean(np.square(np.asarray(x, dtype=float))))


def _ratio_db(num: float, den: float) -> float:
    """``10 log10(num / den)``; ``-inf`` for a zero numerator, ``nan`` for a zero denominator."""
    if den <= 0.0:
        return float("nan")
    if num <= 0.0:
        return float("-inf")
    return float(10.0 * np.log10(num / den))


def speech_jitter_db(w1_speech, w2_speech) -> float:
    """``10 log10 P(W1 s - W2 s) / P(W1 s)`` in dB (``-inf`` for a fixed system).

    >>> s = np.sin(np.arange(1000) / 7.0)
    >>> speech_jitter_db(0.5 * s, 0.5 * s)
    -inf
    >>> round(speech_jitter_db(1.0 * s, 0.9 * s), 2)  # 10 log10(0.1^2) = -20 dB
    -20.0
    """
    w1 = np.asarray(w1_speech, dtype=float)
    w2 = np.asarray(w2_speech, dtype=float)
    if w1.shape != w2.shape:
        raise ValueError(f"W1 s and W2 s differ in shape: {w1.shape} vs {w2.shape}")
    return _ratio_db(_power(w1 - w2), _power(w1))


def hagerman_leak_db(w1_speech, w2_speech, w1_noise, w2_noise) -> float:
    """Power of ``(W1 - W2) s / 2`` re ``(W1 + W2) n / 2``, in dB.

    ``w2_noise`` is ``W2`` applied to ``+n`` (the operation adapted on ``s - n``, replayed on
    the noise with its original sign).

    >>> rng = np.random.default_rng(0)
    >>> s, n = rng.standard_normal(4000), rng.standard_normal(4000)
    >>> hagerman_leak_db(s, s, n, n)  # a fixed system: no leak at all
    -inf
    >>> leak = hagerman_leak_db(1.2 * s, 0.8 * s, 0.5 * n, 0.5 * n)  # 0.2 s against 0.5 n
    >>> closed_form = 10 * np.log10(0.2**2 * np.mean(s**2) / (0.5**2 * np.mean(n**2)))
    >>> round(leak, 2), bool(abs(leak - closed_form) < 1e-9)
    (-8.03, True)
    """
    w1s, w2s, w1n, w2n = (np.asarray(v, dtype=float) for v in (w1_speech, w2_speech, w1_noise, w2_noise))
    if not (w1s.shape == w2s.shape == w1n.shape == w2n.shape):
        raise ValueError("W1 s, W2 s, W1 n and W2 n must have one shape")
    return _ratio_db(_power(0.5 * (w1s - w2s)), _power(0.5 * (w1n + w2n)))
