"""Slow, obviously-correct image-source reference: a triple loop and a scalar windowed sinc.

Written straight from algorithms.md section 3 (Allen & Berkley 1979; Peterson 1986), sharing
no code with ``scenesim.room.ism``: every image (i, j, k) with |i| + |j| + |k| <= N is visited,
its position and per-wall hit counts computed, and an 80-tap Hann-windowed sinc centred on
its true delay added tap by tap.  Used by tests as the oracle for the vectorised renderer.
"""

from __future__ import annotations

import math

import numpy as np

HALF_WIDTH = 40  # window support |t| < 40 samples, as documented for scenesim.room.ism


def _kernel(t: float) -> float:
    if abs(t) >= HALF_WIDTH:
        return 0.0
    w = 0.5 * (1.0 + math.cos(math.pi * t / HALF_WIDTH))
    s = 1.0 if t == 0.0 else math.sin(math.pi * t) / (math.pi * t)
    return w * s


def reference_rir(
    dims, absorption6, source, mic, *, fs, max_order, n_taps, c=343.0, sign=1.0, source_gain=None
):
    """RIR ``(n_taps,)`` at one mic, physical scale ``g / (4 pi r)``, tap 0 = emission.

    ``source_gain(direction)``: optional directivity gain of the emission direction (a unit
    3-vector at the real source).  The path leaves the source along the image-to-mic
    direction with the component of every axis reflected an odd number of times reversed.
    """
    beta = [math.sqrt(1.0 - a) for a in absorption6]
    h = np.zeros(n_taps)
    n = max_order
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            for k in range(-n, n + 1):
                if abs(i) + abs(j) + abs(k) > n:
                    continue
                gain = sign ** (abs(i) + abs(j) + abs(k))
                pos = []
                for axis, idx in enumerate((i, j, k)):
                    length, s = dims[axis], source[axis]
                    pos.append(idx * length + (s if idx % 2 == 0 else length - s))
                    hits = abs(idx)
                    # Hits on the wall at 0: images with negative index start by reflecting there.
                    hits0 = hits // 2 if idx > 0 else (hits + 1) // 2
                    gain *= beta[2 * axis] ** hits0 * beta[2 * axis + 1] ** (hits - hits0)
                r = math.dist(pos, mic)
                if source_gain is not None:
                    emit = [
                        (mic[d] - pos[d]) / r * (-1.0 if abs(idx) % 2 else 1.0)
                        for d, idx in enumerate((i, j, k))
                    ]
                    gain *= source_gain(emit)
                amp = gain / (4.0 * math.pi * r)
                delay = r * fs / c
                first = math.floor(delay) - HALF_WIDTH + 1
                for tap in range(first, first + 2 * HALF_WIDTH):
                    if 0 <= tap < n_taps:
                        h[tap] += amp * _kernel(tap - delay)
    return h
