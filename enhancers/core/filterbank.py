"""Weighted overlap-add (WOLA) filter bank with a streaming step (algorithms.md section 6).

Analysis: frame ``l`` covers input samples ``[l R + R - N, l R + R - 1]`` (samples before
time 0 are zero), is multiplied by the analysis window ``w_a`` (periodic Hamming) and
transformed with ``rfft``.  Frame ``l`` is therefore complete when sample ``l R + R - 1``
arrives.  Synthesis: ``irfft``, multiply by the synthesis window ``w_s`` and overlap-add.
``w_s`` is the canonical dual window ``w_s[n] = w_a[n] / sum_k w_a[n + k R]^2``, so
``sum_k w_a[n - k R] w_s[n - k R] = 1``: unit gains reconstruct the input exactly.

A causal streaming WOLA can emit a sample only once every frame covering it has been
processed, so the output is the reconstruction delayed by ``latency = N - 1`` samples:
``y[n] = xhat[n - (N - 1)]``.  Batch processing runs the very same step on the whole
signal, so batch output equals the concatenated block outputs for any block size.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import get_window

from scenesim.errors import ParameterError
from scenesim.validate import check_int

__all__ = ["FilterBank", "FilterBankState", "frame_len_for"]


def frame_len_for(fs: int, *, frame_ms: float = 16.0) -> int:
    """Frame length in samples for ``frame_ms`` at ``fs`` Hz, rounded to an even number (256 at 16 kHz)."""
    return max(2, 2 * int(round(frame_ms * 1e-3 * fs / 2)))


@dataclass
class FilterBankState:
    """Streaming state of one :class:`FilterBank` stream.

    Attributes
    ----------
    tail : ndarray, shape (n_channels, N - 1)
        Last ``N - 1`` input samples (zeros before time 0).
    phase : int
        Samples received modulo the hop.
    ola : ndarray, shape (n_channels, q R - R)
        Partial overlap-add sums for the samples after the last emitted one (``q = ceil(N/R)``).
    queue : ndarray, shape (n_channels, n_queued)
        Completed output samples not yet returned (initially ``R - 1`` zeros).
    """

    tail: np.ndarray
    phase: int
    ola: np.ndarray
    queue: np.ndarray


@dataclass(frozen=True)
class FilterBank:
    """WOLA analysis/synthesis pair (immutable configuration).

    Parameters
    ----------
    frame_len : int
        Window length ``N`` in samples (default 256 = 16 ms at 16 kHz).
    hop : int
        Hop ``R`` in samples, ``1 <= R <= N`` (default 128: 50 % overlap).
    window : str
        Analysis window name for :func:`scipy.signal.get_window` (periodic), default Hamming.
    """

    frame_len: int = 256
    hop: int = 128
    window: str = "hamming"
    _windows: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        n = check_int("frame_len", self.frame_len, minimum=2)
        r = check_int("hop", self.hop, minimum=1, maximum=n)
        if not isinstance(self.window, str):  # get_window would take a float as a Kaiser beta
            raise ParameterError("window", self.window, "a scipy.signal.get_window name (str)")
        try:
            wa = np.asarray(get_window(self.window, n, fftbins=True), dtype=float)
        except (ValueError, TypeError):
            raise ParameterError("window", self.window, "a scipy.signal.get_window name") from None
        q = -(-n // r)
        padded = np.zeros(q * r)
        padded[:n] = wa**2
        denom = padded.reshape(q, r).sum(axis=0)
        if np.min(denom) <= 1e-12 * np.max(denom):
            raise ParameterError("hop", r, f"a hop for which the {self.window} window overlaps (no gaps)")
        ws = wa / np.tile(denom, q)[:n]
        object.__setattr__(self, "frame_len", n)
        object.__setattr__(self, "hop", r)
        object.__setattr__(self, "_windows", (wa, ws))

    # -- derived -----------------------------------------------------------------------
    @property
    def analysis_window(self) -> np.ndarray:
        return self._windows[0]

    @property
    def synthesis_window(self) -> np.ndarray:
        return self._windows[1]

    @property
    def n_bins(self) -> int:
        return self.frame_len // 2 + 1

    @property
    def latency_samples(self) -> int:
        """Delay of the output behind the input, ``N - 1`` samples."""
        return self.frame_len - 1

    @property
    def _q(self) -> int:
        return -(-self.frame_len // self.hop)

    def n_frames(self, n_samples: int) -> int:
        """Frames completed by ``n_samples`` samples from a fresh state: ``n_samples // R``."""
        return n_samples // self.hop

    # -- streaming -----------------------------------------------------------------------
    def init_state(self, n_channels: int = 1) -> FilterBankState:
        n, r = self.frame_len, self.hop
        return FilterBankState(
            tail=np.zeros((n_channels, n - 1)),
            phase=0,
            ola=np.zeros((n_channels, (self._q - 1) * r)),
            queue=np.zeros((n_channels, r - 1)),
        )

    def analysis_step(self, block: np.ndarray, state: FilterBankState) -> tuple[np.ndarray, FilterBankState]:
        """Spectra of the frames completed inside ``block``.

        Parameters
        ----------
        block : ndarray, shape (n_channels, b)
        state : FilterBankState (only ``tail`` and ``phase`` are read or replaced here)

        Returns
        -------
        X : ndarray, complex, shape (n_channels, n_frames, n_bins)
        state : the updated state (``tail``, ``phase``); pass it on to :meth:`synthesis_step`.
        """
        n, r = self.frame_len, self.hop
        b = block.shape[-1]
        ext = np.concatenate((state.tail, block), axis=-1)
        # frame ends (block-relative) at times where (phase + j + 1) % R == 0
        first_end = (r - 1 - state.phase) % r
        m = 0 if first_end >= b else (b - 1 - first_end) // r + 1  # frames completed in the block
        wa = self._windows[0]
        # in ext coordinates a frame ending at block index j spans [j, j + N - 1]
        if m == 1:  # streaming at the hop: one frame, a plain slice (per-block overhead matters there)
            X = np.fft.rfft(ext[:, first_end:first_end + n] * wa, axis=-1)[:, None]
        elif m:
            frames = sliding_window_view(ext, n, axis=-1)[:, first_end::r][:, :m]
            X = np.fft.rfft(frames * wa, axis=-1)
        else:
            X = np.zeros((block.shape[0], 0, n // 2 + 1), dtype=complex)
        new = FilterBankState(
            tail=ext[:, ext.shape[-1] - (n - 1):].copy(),
            phase=(state.phase + b) % r,
            ola=state.ola,
            queue=state.queue,
        )
        return X, new

    def synthesis_step(self, Y: np.ndarray, n_out: int, state: FilterBankState) -> tuple[np.ndarray, FilterBankState]:
        """Overlap-add the frames ``Y`` (``(n_channels, n_frames, n_bins)``) and return ``n_out`` samples.

        ``Y`` must hold exactly the frames :meth:`analysis_step` returned for a block of
        ``n_out`` samples; the output is then that block's samples delayed by ``N - 1``.
        """
        n, r, q = self.frame_len, self.hop, self._q
        n_ch, n_fr = Y.shape[0], Y.shape[1]
        if n_fr == 1:  # streaming at the hop: one frame, no accumulator (the same sums)
            frame = np.fft.irfft(Y[:, 0], n=n, axis=-1)
            frame *= self._windows[1]
            if q * r != n:
                frame = np.concatenate([frame, np.zeros((n_ch, q * r - n))], axis=-1)
            frame[:, : (q - 1) * r] += state.ola
            queue = np.concatenate([state.queue, frame[:, :r]], axis=-1)
            ola = frame[:, r:]
        elif n_fr:
            frames = np.fft.irfft(Y, n=n, axis=-1) * self.synthesis_window
            if q * r != n:
                frames = np.concatenate([frames, np.zeros((n_ch, n_fr, q * r - n))], axis=-1)
            parts = frames.reshape(n_ch, n_fr, q, r)
            acc = np.zeros((n_ch, n_fr + q - 1, r))
            for j in range(q):  # q = N/R (2 for 50 % overlap): loop over overlap, not frames/bins
                acc[:, j:j + n_fr, :] += parts[:, :, j, :]
            acc = acc.reshape(n_ch, -1)
            acc[:, : (q - 1) * r] += state.ola
            done, ola = acc[:, : n_fr * r], acc[:, n_fr * r:].copy()
            queue = np.concatenate([state.queue, done], axis=-1)
        else:
            queue, ola = state.queue, state.ola
        out = queue[:, :n_out]
        new = FilterBankState(tail=state.tail, phase=state.phase, ola=ola, queue=queue[:, n_out:].copy())
        return out, new

    # -- batch helpers ---------------------------------------------------------------------
    def analyze(self, x: np.ndarray) -> np.ndarray:
        """Batch analysis from a fresh state: ``(n_channels, n)`` -> ``(n_channels, n // R, n_bins)``."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        X, _ = self.analysis_step(x, self.init_state(x.shape[0]))
        return X

    def synthesize(self, Y: np.ndarray, n_samples: int) -> np.ndarray:
        """Batch synthesis of all frames of an ``n_samples`` signal (output delayed by ``N - 1``)."""
        out, _ = self.synthesis_step(Y, n_samples, self.init_state(Y.shape[0]))
        return out
