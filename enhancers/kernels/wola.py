"""Compiled (numba) WOLA analysis / synthesis of one frame, for the fused streaming step of
:mod:`enhancers.kernels.frames` and of ``ss_block`` / ``beam_block`` in :mod:`enhancers.kernels.stream` (the
same filter bank as :class:`enhancers.core.filterbank.FilterBank`; :func:`block_frames` ... :func:`finish_block`
are the block's framing and overlap-add bookkeeping, the state layout of ``fast_frames.wola_state``).

Why: a 10 ms block is one or two frames, and numpy's ``rfft`` / ``irfft`` calls plus the filter
bank's bookkeeping cost more per block than the frames' processing.  Here a radix-2 FFT (frame
length a power of two) runs inside the block's kernel call.  Two real frames share one complex
FFT (``x1 + j x2``; the spectra separate by conjugate symmetry), and so do two output channels.
Results equal numpy's ``rfft`` / ``irfft`` to rounding (~1e-16 of the frame's norm per bin).
"""

from __future__ import annotations

import numba
import numpy as np


def fft_tables(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(bit-reversal permutation (n,), tw (2, n/2))``: ``tw`` = cos and sin of ``2 pi m / n`` for :func:`fft`."""
    bits = n.bit_length() - 1
    rev = np.array([int(format(i, f"0{bits}b")[::-1], 2) for i in range(n)], dtype=np.int64)
    m = np.arange(n // 2)
    return rev, np.stack([np.cos(2 * np.pi * m / n), np.sin(2 * np.pi * m / n)])


@numba.njit(cache=True)
def fft(re, im, rev, tw):  # pragma: no cover - compiled; tests/test_fast_frames.py compares it with numpy
    """In-place forward DFT ``sum_t z[t] e^{-2 pi j f t / n}`` of ``re + j im`` (``n`` a power of two)."""
    n = re.shape[0]
    for i in range(n):
        j = rev[i]
        if j > i:
            re[i], re[j] = re[j], re[i]
            im[i], im[j] = im[j], im[i]
    size = 2
    while size <= n:
        half = size // 2
        step = n // size
        for start in range(0, n, size):
            for k in range(half):
                wr = tw[0, k * step]
                wi = -tw[1, k * step]
                a = start + k
                b = a + half
                tr = wr * re[b] - wi * im[b]
                ti = wr * im[b] + wi * re[b]
                re[b] = re[a] - tr
                im[b] = im[a] - ti
                re[a] += tr
                im[a] += ti
        size *= 2


@numba.njit(cache=True)
def analyze_pair(x1, x2, wa, rev, tw, X1, X2):  # pragma: no cover - compiled
    """``X1, X2 (n/2 + 1,)`` = ``rfft(x1 wa)``, ``rfft(x2 wa)`` from one complex FFT of ``x1 wa + j x2 wa``."""
    n = wa.shape[0]
    re = np.empty(n)
    im = np.empty(n)
    for t in range(n):
        re[t] = x1[t] * wa[t]
        im[t] = x2[t] * wa[t]
    fft(re, im, rev, tw)
    for k in range(n // 2 + 1):
        m = (n - k) % n
        # Z[k] = A[k] + j B[k] with A, B Hermitian: A = (Z[k] + conj Z[-k]) / 2, B = (Z[k] - conj Z[-k]) / 2j
        X1[k] = complex(0.5 * (re[k] + re[m]), 0.5 * (im[k] - im[m]))
        X2[k] = complex(0.5 * (im[k] + im[m]), 0.5 * (re[m] - re[k]))


@numba.njit(cache=True)
def synthesize(Y1, Y2, two, ws, rev, tw, y1, y2):  # pragma: no cover - compiled
    """``y1 = irfft(Y1) ws`` (and ``y2`` from ``Y2`` when ``two``), from one complex inverse FFT.

    As numpy's ``irfft``, the imaginary parts of the DC and Nyquist bins are ignored."""
    n = ws.shape[0]
    h = n // 2
    re = np.empty(n)
    im = np.empty(n)
    for k in range(h + 1):  # W = Y1 + j Y2, extended Hermitian per channel; conj(W) for the inverse via fft
        a = Y1[k]
        b = Y2[k] if two else 0j
        if k == 0 or k == h:
            a = complex(a.real, 0.0)
            b = complex(b.real, 0.0)
        re[k] = a.real - b.imag
        im[k] = -(a.imag + b.real)
        if 0 < k < h:
            re[n - k] = a.real + b.imag
            im[n - k] = -(b.real - a.imag)
    fft(re, im, rev, tw)
    for t in range(n):  # ifft(W) = conj(fft(conj W)) / n: real part -> y1, imaginary part -> y2
        y1[t] = re[t] / n * ws[t]
        if two:
            y2[t] = -im[t] / n * ws[t]


@numba.njit(cache=True)
def block_frames(block, tail, wst):  # pragma: no cover - compiled
    """``(ext, first_end, m)`` of a streaming block ``(C, b)``: ``ext = [tail | block]`` and the ``m`` frames
    completed in it, the frame ending at block index ``e = first_end + j R`` spanning ``ext[:, e:e + N]``
    (enhancers.core.filterbank's frames; ``wst`` = (samples received modulo R, queued samples, R))."""
    n1 = tail.shape[1]
    r = wst[2]
    b = block.shape[1]
    ext = np.empty((block.shape[0], n1 + b))
    for c in range(block.shape[0]):  # loops, not slice assignments: numba compiles these far faster
        for t in range(n1):
            ext[c, t] = tail[c, t]
        for t in range(b):
            ext[c, n1 + t] = block[c, t]
    first_end = (r - 1 - wst[0]) % r  # frame ends (block-relative) where (phase + j + 1) % R == 0
    m = 0 if first_end >= b else (b - 1 - first_end) // r + 1
    return ext, first_end, m


@numba.njit(cache=True)
def output_buffer(queue, wst, m):  # pragma: no cover - compiled
    """``(C, ql + m R)`` buffer of the block's output samples, starting with the ``ql`` queued ones."""
    ql = wst[1]
    buf = np.empty((queue.shape[0], ql + m * wst[2]))
    for c in range(queue.shape[0]):
        for t in range(ql):
            buf[c, t] = queue[c, t]
    return buf


@numba.njit(cache=True)
def overlap_add(y, c, j, ola, buf, wst):  # pragma: no cover - compiled
    """Overlap-add the synthesised frame ``j`` ``y (N,)`` of channel ``c``: its first ``R`` samples are
    complete (into ``buf``), the rest become the partial sums ``ola[c]`` (``y`` is overwritten)."""
    r = wst[2]
    ql = wst[1]
    for t in range(y.shape[0] - r):
        y[t] += ola[c, t]
    for t in range(r):
        buf[c, ql + j * r + t] = y[t]
    for t in range(y.shape[0] - r):
        ola[c, t] = y[r + t]


@numba.njit(cache=True)
def finish_block(ext, buf, m, tail, queue, wst):  # pragma: no cover - compiled
    """Keep the state after a block of ``b`` samples (``tail``, ``queue``, ``wst``) and return its ``(C, b)`` output."""
    r = wst[2]
    b = ext.shape[1] - tail.shape[1]
    new_ql = wst[1] + m * r - b
    for c in range(queue.shape[0]):
        for t in range(new_ql):
            queue[c, t] = buf[c, b + t]
    for c in range(tail.shape[0]):
        for t in range(tail.shape[1]):
            tail[c, t] = ext[c, b + t]
    wst[0], wst[1] = (wst[0] + b) % r, new_ql
    return buf[:, :b]


@numba.njit(cache=True)
def synthesize_frames(Y, m, ws, rev, tw, ola, queue, wst):  # pragma: no cover - compiled
    """Synthesis and overlap-add of one channel's ``m`` frames ``Y (>= m + 1, K)`` (two frames per
    inverse FFT; row ``m`` is scratch): the ``(1, ql + m R)`` buffer for :func:`finish_block`."""
    buf = output_buffer(queue, wst, m)
    y = np.empty((2, ws.shape[0]))
    for j in range(0, m, 2):
        synthesize(Y[j], Y[j + 1], j + 1 < m, ws, rev, tw, y[0], y[1])
        overlap_add(y[0], 0, j, ola, buf, wst)
        if j + 1 < m:
            overlap_add(y[1], 0, j + 1, ola, buf, wst)
    return buf
