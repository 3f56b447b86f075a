"""Two-channel weighted prediction error dereverberation (WPE; Nakatani et al. 2010) via ``nara-wpe``.

Optional: ``pip install -e '.[wpe]'`` (``nara-wpe``, MIT, numpy; Drude et al. 2018).
Nothing is downloaded.

WPE predicts each STFT bin's late reverberation from the frames ``delay .. delay + taps - 1``
before it (all channels) and subtracts the prediction; the prediction filter ``G`` (one per
frequency) is re-estimated ``iterations`` times, weighting frames by the inverse power of
the current estimate.  This is ``nara_wpe.wpe.wpe_v7`` step for step (built from its own
``build_y_tilde``, ``get_power_inverse``, ``get_filter_matrix_v7`` and
``perform_filter_operation_v5``, checked equal to it in tests/test_wpe.py), kept apart so
the final ``G`` is known: once estimated, WPE is a fixed linear filter per frequency, so
``Result.replay`` applies the same ``G`` to a speech or noise image exactly (replayable).

Defaults are ``nara-wpe``'s documented example for 16 kHz: STFT size 512, shift 128
(``nara_wpe.utils.stft``: Blackman window), ``taps = 10``, ``delay = 3``, ``iterations = 5``.
Offline (the whole signal estimates ``G``): no streaming; the output is time aligned with
the input (latency 0).  Cost: see ``python -m benchmarks.perf.enhancer_rtf``.  2 channels in, 2 out (both mics dereverberated), so it feeds a
two-mic beamformer: ``wpe-eb-robust`` and ``wpe-eb-robust-ss``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from nara_wpe import wpe as _wpe
from nara_wpe.utils import istft, stft

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from enhancers.core.chain import Chain
from scenesim.validate import check_int

__all__ = ["Wpe", "WpeEbRobust", "WpeEbRobustSs", "wpe_filter"]


def wpe_filter(Y: np.ndarray, *, taps: int, delay: int, iterations: int) -> np.ndarray:
    """WPE prediction filter of an STFT ``Y`` (F, D, T): ``G`` (F, D * taps, D), as ``wpe_v7`` computes it.

    ``wpe_v7``'s loop, with the conjugate transposes of ``Y`` and of the stacked past frames
    ``Y_tilde`` made once instead of in every iteration (``wpe_v7`` spends about half its
    time re-conjugating the strided ``Y_tilde`` view); the arithmetic is the same.
    """
    Y_tilde = np.ascontiguousarray(_wpe.build_y_tilde(Y, taps, delay))
    Y_tilde_h = np.ascontiguousarray(_wpe.hermite(Y_tilde))
    Y_h = np.ascontiguousarray(_wpe.hermite(Y))
    X = Y
    G = None
    for i in range(iterations):
        weighted = Y_tilde * _wpe.get_power_inverse(X, psd_context=0)[..., None, :]
        G = _wpe._stable_solve(weighted @ Y_tilde_h, weighted @ Y_h)  # R G = P (get_filter_matrix_v7)
        if i + 1 < iterations:
            X = _wpe.perform_filter_operation_v5(Y=Y, Y_tilde=Y_tilde, filter_matrix=G)
    return G


class Wpe(Enhancer):
    """Offline two-channel WPE (``nara-wpe``), 2 channels in and out, replayable.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((2, 16000))
    >>> result = Wpe().process(x, 16000)
    >>> result.output.shape, bool(np.allclose(result.replay(x), result.output))
    ((2, 16000), True)
    """

    name: ClassVar[str] = "wpe"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "weighted prediction error dereverberation (nara-wpe), 2 in / 2 out, offline"

    @dataclass(frozen=True)
    class Params(Params):
        """``taps`` (frames predicted from), ``delay`` (frames skipped: the early part kept),
        ``iterations``, ``stft_size`` and ``stft_shift`` (samples)."""

        taps: int = 10
        delay: int = 3
        iterations: int = 5
        stft_size: int = 512
        stft_shift: int = 128

        def __post_init__(self):
            check_int("taps", self.taps, minimum=1, maximum=100)
            check_int("delay", self.delay, minimum=1, maximum=100)
            check_int("iterations", self.iterations, minimum=1, maximum=50)
            size = check_int("stft_size", self.stft_size, minimum=16, maximum=8192)
            check_int("stft_shift", self.stft_shift, minimum=1, maximum=size // 2)

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=2, channels_out=2, streaming=False, latency_samples=0)

    def _stft(self, x: np.ndarray) -> np.ndarray:
        """(D, n) -> (F, D, T), nara-wpe's layout."""
        return stft(x, self.params.stft_size, self.params.stft_shift).transpose(2, 0, 1)

    def _istft(self, Z: np.ndarray, n: int) -> np.ndarray:
        y = istft(Z.transpose(1, 2, 0), self.params.stft_size, self.params.stft_shift)
        return np.ascontiguousarray(y[:, :n], dtype=np.float64)

    def _process(self, x: np.ndarray, fs: int) -> Result:
        n = x.shape[-1]
        p = self.params
        Y = self._stft(x)
        G = wpe_filter(Y, taps=p.taps, delay=p.delay, iterations=p.iterations)

        def apply(component: np.ndarray) -> np.ndarray:
            C = self._stft(component)
            C_tilde = _wpe.build_y_tilde(C, p.taps, p.delay)
            return self._istft(_wpe.perform_filter_operation_v5(Y=C, Y_tilde=C_tilde, filter_matrix=G), n)

        def replay(component) -> np.ndarray:
            return apply(check_component(component, x.shape))

        return Result(output=apply(x), trace={}, _replay=replay)


class WpeEbRobust(Chain):
    """``wpe`` then ``eb-robust``: both mics dereverberated, then the robust two-mic beamformer."""

    name = "wpe-eb-robust"
    version = "1"
    summary = "WPE dereverberation (nara-wpe) followed by the robust sub-band beamformer"
    stages = (("wpe", "wpe"), ("eb", "eb-robust"))


class WpeEbRobustSs(Chain):
    """``wpe`` then ``eb-robust`` then ``ss``: dereverberation, beamforming, noise suppression."""

    name = "wpe-eb-robust-ss"
    version = "1"
    summary = "WPE dereverberation, robust sub-band beamformer, spectral subtraction"
    stages = (("wpe", "wpe"), ("eb", "eb-robust"), ("ss", "ss"))
