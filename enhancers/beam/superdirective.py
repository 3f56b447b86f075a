"""Fixed two-mic superdirective beamformer: MVDR for the diffuse field with a white-noise-gain floor.

The classic fixed peer of the differential pair (``cardioid``, ``hypercardioid``).  Per
frequency ``f`` (on the WOLA filter bank of :mod:`enhancers.core.filterbank`)::

    d(f)      = [1, exp(-j 2 pi f T)],   T = spacing_m cos(look_az_deg) / c_mps
                                          steering vector, relative to the reference mic p1
    Gamma(f)  = [[1, g], [g, 1]],        g = sinc(2 f spacing_m / c_mps)    (numpy sinc:
                                          sin(pi x) / (pi x); spherically isotropic noise)
    w(f)      = (Gamma + mu I)^-1 d / (d^H (Gamma + mu I)^-1 d)              MVDR, loaded
    Y(f)      = w^H X(f)                  distortionless: the look direction passes as at p1

Diagonal loading ``mu >= 0`` is chosen per bin as the smallest value for which the
white-noise gain ``WNG = |w^H d|^2 / (w^H w)`` is at least ``wng_min_db`` (Cox, Zeskind &
Kooij 1987: WNG grows monotonically with ``mu``, from the unconstrained superdirective
array at ``mu = 0`` to delay-and-sum, ``WNG = 2``, as ``mu -> inf``); found by bisection
on ``log10 mu``, vectorized over bins.  At low frequency the unconstrained pair tends to
the endfire hypercardioid (directivity index ``10 log10 4 = 6.02`` dB) with a WNG that
falls as ``f^-4``; the floor trades that directivity for robustness to sensor noise and
mismatch.

Directivity index and WNG of any weights: :func:`directivity_db`, :func:`wng_db`.

Streaming blocks of up to :data:`enhancers.kernels.stream.MAX_BLOCK` samples run in one numba call
(:func:`enhancers.kernels.stream.beam_block`: analysis, weights, synthesis; power-of-two frame
lengths); the numpy filter-bank steps stay the reference (``MAX_BLOCK = 0``) and batch's path.

Reference: H. Cox, R. M. Zeskind, T. Kooij, "Practical supergain", IEEE TASSP 34(3), 1986;
H. Cox, R. M. Zeskind, M. M. Owen, "Robust adaptive beamforming", IEEE TASSP 35(10), 1987;
J. Bitzer, K. U. Simmer, "Superdirective microphone arrays", in Microphone Arrays (2001).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from enhancers.core.filterbank import FilterBank, FilterBankState
from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_int, check_positive, check_range

__all__ = ["Superdirective", "diffuse_coherence", "directivity_db", "steering_vector",
           "superdirective_weights", "wng_db"]

WNG_MAX_DB = 10.0 * np.log10(2.0)
"""Largest WNG of two mics (delay-and-sum), 3.01 dB: a floor above it cannot be met."""

_MU_MIN, _MU_MAX = 1e-12, 1e8  # bisection range of the loading (relative to unit diagonal)
_BISECT_STEPS = 60  # log10-range 20 halved 60 times: mu to 1e-17 decades, far below need
_TINY = 1e-300


def steering_vector(freqs_hz, *, spacing_m: float, c_mps: float, look_az_deg: float = 0.0) -> np.ndarray:
    """``(n_freqs, 2)`` plane-wave response ``[1, exp(-j 2 pi f T)]``, ``T = d cos(look) / c``.

    Example
    -------
    >>> steering_vector([0.0], spacing_m=0.02, c_mps=343.0).tolist()
    [[(1+0j), (1+0j)]]
    """
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    tau = spacing_m * np.cos(np.radians(look_az_deg)) / c_mps
    return np.stack([np.ones_like(f, dtype=complex), np.exp(-2j * np.pi * f * tau)], axis=-1)


def diffuse_coherence(freqs_hz, *, spacing_m: float, c_mps: float) -> np.ndarray:
    """Spherically isotropic (diffuse) noise coherence ``sinc(2 f d / c)`` per frequency, ``(n_freqs,)``."""
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    return np.sinc(2.0 * f * spacing_m / c_mps)


def _mvdr(d: np.ndarray, g: np.ndarray, mu: np.ndarray) -> np.ndarray:
    # (Gamma + mu I)^-1 d up to the scalar 1/det, which the normalisation cancels:
    # for [[a, g], [g, a]] the adjugate is [[a, -g], [-g, a]] (no division by a small det).
    a = 1.0 + mu
    u = np.stack([a * d[:, 0] - g * d[:, 1], a * d[:, 1] - g * d[:, 0]], axis=-1)
    den = np.sum(np.conj(d) * u, axis=-1)
    den = np.where(np.abs(den) < _TINY, _TINY, den)
    return u / np.conj(den)[:, None]  # w^H d = 1


def wng_db(w: np.ndarray, d: np.ndarray) -> np.ndarray:
    """White-noise gain ``10 log10(|w^H d|^2 / (w^H w))`` per row of ``w``, ``d`` (``(n_freqs, 2)``)."""
    num = np.abs(np.sum(np.conj(w) * d, axis=-1)) ** 2
    return 10.0 * np.log10(np.maximum(num, _TINY) / np.maximum(np.sum(np.abs(w) ** 2, axis=-1), _TINY))


def directivity_db(w: np.ndarray, d: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Directivity index ``10 log10(|w^H d|^2 / (w^H Gamma w))`` against diffuse coherence ``g``."""
    num = np.abs(np.sum(np.conj(w) * d, axis=-1)) ** 2
    quad = np.abs(w[:, 0]) ** 2 + np.abs(w[:, 1]) ** 2 + 2.0 * g * np.real(np.conj(w[:, 0]) * w[:, 1])
    return 10.0 * np.log10(np.maximum(num, _TINY) / np.maximum(quad, _TINY))


def superdirective_weights(freqs_hz, *, spacing_m: float, c_mps: float, look_az_deg: float = 0.0,
                           wng_min_db: float | None = -10.0) -> tuple[np.ndarray, np.ndarray]:
    """Weights ``w`` (``(n_freqs, 2)``, ``Y = w^H X``) and the loading ``mu`` (``(n_freqs,)``) per frequency.

    ``wng_min_db=None`` gives the unconstrained superdirective array (``mu = 1e-12``, a
    numerical guard only).  Otherwise ``mu`` is the smallest loading with
    ``WNG >= wng_min_db`` (bisection on ``log10 mu``; bins that meet the floor unloaded keep
    ``mu = 1e-12``).

    Example
    -------
    At 300 Hz the unloaded array has a WNG of -19.1 dB, so the loading lifts it to the floor;
    at 1 kHz it is -8.8 dB unloaded and the floor leaves it alone:

    >>> f = [300.0, 1000.0]
    >>> w, mu = superdirective_weights(f, spacing_m=0.0214, c_mps=343.0)
    >>> [round(float(v), 2) for v in wng_db(w, steering_vector(f, spacing_m=0.0214, c_mps=343.0))]
    [-10.0, -8.76]
    >>> bool(mu[1] == 1e-12)
    True
    """
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    d = steering_vector(f, spacing_m=spacing_m, c_mps=c_mps, look_az_deg=look_az_deg)
    g = diffuse_coherence(f, spacing_m=spacing_m, c_mps=c_mps)
    mu = np.full(f.shape, _MU_MIN)
    if wng_min_db is None:
        return _mvdr(d, g, mu), mu
    ok = wng_db(_mvdr(d, g, mu), d) >= wng_min_db
    lo = np.full(f.shape, np.log10(_MU_MIN))
    hi = np.full(f.shape, np.log10(_MU_MAX))
    for _ in range(_BISECT_STEPS):  # invariant: WNG(10**lo) < floor <= WNG(10**hi)
        mid = 0.5 * (lo + hi)
        meets = wng_db(_mvdr(d, g, 10.0**mid), d) >= wng_min_db
        hi = np.where(meets, mid, hi)
        lo = np.where(meets, lo, mid)
    mu = np.where(ok, _MU_MIN, 10.0**hi)
    return _mvdr(d, g, mu), mu


@dataclass
class _SdState:
    analysis: FilterBankState  # 2 channels in (tail, phase)
    synthesis: FilterBankState  # 1 channel out (overlap-add, queue)
    fs: int
    wc: np.ndarray | None = None  # conj(w).T at fs, (2, n_bins): read per block, so kept here
    #: While blocks run through the fused kernel (``stream_kernels.beam_block``): its filter-bank arrays,
    #: which then hold the state instead of ``analysis`` / ``synthesis``.
    fused: tuple | None = None


@functools.lru_cache(maxsize=32)
def _filterbank(frame_len: int, hop: int, window: str) -> FilterBank:
    return FilterBank(frame_len=frame_len, hop=hop, window=window)


@functools.lru_cache(maxsize=64)
def _weights(params: Superdirective.Params, fs: int) -> np.ndarray:
    freqs = np.fft.rfftfreq(params.frame_len, 1.0 / fs)
    w, _ = superdirective_weights(freqs, spacing_m=params.spacing_m, c_mps=params.c_mps,
                                  look_az_deg=params.look_az_deg, wng_min_db=params.wng_min_db)
    w.setflags(write=False)
    return w


class Superdirective(Enhancer):
    """Fixed 2-mic superdirective (diffuse-field MVDR) beamformer with a WNG floor (Cox 1987).

    Two channels in (p1 front/reference, p2), one out; needs the array geometry
    (``spacing_m``, ``c_mps``).  Steered to ``look_az_deg`` (0 = endfire, p1's side).
    ``trace["weights"]``: ``(n_bins, 2)`` complex weights ``w`` (``Y = w^H X``).
    Latency ``frame_len - 1`` samples (WOLA filter bank).  A fixed linear filter, so
    ``replay`` is exact.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((2, 16000))
    >>> Superdirective().process(x, 16000).output.shape
    (1, 16000)
    """

    name: ClassVar[str] = "superdirective"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "fixed 2-mic superdirective (diffuse MVDR) with a white-noise-gain floor"

    @dataclass(frozen=True)
    class Params(Params):
        spacing_m: float = 0.0214
        c_mps: float = 343.0
        look_az_deg: float = 0.0
        wng_min_db: float = -10.0
        frame_len: int = 256
        hop: int = 128
        window: str = "hamming"

        def __post_init__(self):
            check_positive("spacing_m", self.spacing_m)
            check_positive("c_mps", self.c_mps)
            check_finite_number("look_az_deg", self.look_az_deg)
            check_finite_number("wng_min_db", self.wng_min_db)
            check_range("wng_min_db", self.wng_min_db, -60.0, WNG_MAX_DB)
            n = check_int("frame_len", self.frame_len, minimum=16)
            check_int("hop", self.hop, minimum=1, maximum=n)
            if n % self.hop:
                raise ParameterError("hop", self.hop, f"a divisor of frame_len={n}")
            FilterBank(frame_len=self.frame_len, hop=self.hop, window=self.window)

    @functools.cached_property
    def filterbank(self) -> FilterBank:  # params are frozen (cached: read per block)
        p = self.params
        return _filterbank(p.frame_len, p.hop, p.window)

    @functools.cached_property
    def tags(self) -> Tags:
        return Tags(channels_in=2, channels_out=1, needs_geometry=True, streaming=True,
                    latency_samples=self.params.frame_len - 1)

    def weights(self, fs: int) -> np.ndarray:
        """``(n_bins, 2)`` weights at ``fs`` (cached; read-only)."""
        return _weights(self.params, int(fs))

    def _apply(self, X: np.ndarray, fs: int) -> np.ndarray:
        w = self.weights(fs)
        return np.einsum("ck,cfk->fk", np.conj(w.T), X)[None]

    def _init_state(self, fs: int) -> _SdState:
        fb = self.filterbank
        wc = np.ascontiguousarray(np.conj(self.weights(fs).T))  # Y = wc[0] X[0] + wc[1] X[1]
        return _SdState(analysis=fb.init_state(2), synthesis=fb.init_state(1), fs=fs, wc=wc)

    @functools.cached_property
    def _wola(self):
        """Fresh fused-kernel filter-bank arrays (a callable), None when the frame length is not a power of two."""
        from enhancers.kernels.frames import wola_maker

        return wola_maker(self.filterbank, 1)

    def _process_block(self, block: np.ndarray, state: _SdState):
        """Blocks of up to ``stream_kernels.MAX_BLOCK`` samples: one compiled call
        (:func:`enhancers.kernels.stream.beam_block`) when the frame length is a power of two; the
        numpy steps below stay the reference (and batch's path)."""
        if 0 < block.shape[-1] and self._wola is not None:
            import enhancers.kernels.stream as sk  # lazy: numba's import is only paid when streaming

            if block.shape[-1] <= sk.MAX_BLOCK:
                if state.fused is None:
                    from enhancers.kernels.frames import wola_from

                    state.fused = wola_from(self._wola(), state.analysis, state.synthesis)
                return sk.beam_block(np.ascontiguousarray(block, dtype=float), *state.fused, state.wc), state
        if state.fused is not None:  # back to the numpy steps: they take the state over
            from enhancers.kernels.frames import wola_back

            state.analysis = state.synthesis = wola_back(state.fused)
            state.fused = None
        fb = self.filterbank
        X, state.analysis = fb.analysis_step(block, state.analysis)
        if X.shape[1]:
            # 1-2 frames per 10 ms block: two products beat einsum's set-up (the same sums, to rounding)
            wc = state.wc
            X = (wc[0] * X[0] + wc[1] * X[1])[None]
        else:
            X = X[:1]
        out, state.synthesis = fb.synthesis_step(X, block.shape[-1], state.synthesis)
        return out, state  # updated in place (the contract allows it): no new state per block

    def _process(self, x: np.ndarray, fs: int) -> Result:
        fb = self.filterbank
        n = x.shape[-1]
        out = fb.synthesize(self._apply(fb.analyze(x), fs), n)

        def replay(component) -> np.ndarray:
            comp = check_component(component, (2, n))
            return fb.synthesize(self._apply(fb.analyze(comp), fs), n)

        return Result(output=out, trace={"weights": np.array(self.weights(fs))}, _replay=replay)
