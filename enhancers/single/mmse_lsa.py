"""MMSE log-spectral-amplitude estimator (Ephraim & Malah 1985) on the Martin 2001 noise tracker.

The classic single-channel peer of spectral subtraction (``ss``): same WOLA filter bank
(16 ms Hamming, 50 % overlap at 16 kHz), same noise PSD tracker as ``ss-ms2001``
(:func:`enhancers.single.noise_tracking.ms2001_step`, VOICEBOX ``estnoisem`` defaults), a
different gain rule.  Per frame ``l`` and bin ``k``::

    lambda_d  = Pn[l]                                 Martin 2001 noise PSD
    gamma     = |X|^2 / lambda_d                      a-posteriori SNR          (EM84 eq. 9)
    xi        = max(alpha G[l-1]^2 gamma[l-1] + (1 - alpha) max(gamma - 1, 0), xi_min)
                                                      decision-directed a-priori SNR (EM84 eq. 51)
    v         = xi gamma / (1 + xi)
    G         = xi / (1 + xi) exp(0.5 E1(v))          LSA gain                  (EM85 eq. 20)
    G         = min(G, gain_max)                      (gain_max = 1 by default, see below)
    Y         = G X                                   -> WOLA synthesis

``E1`` is the exponential integral (:func:`scipy.special.exp1`).  ``G[l-1]^2 gamma[l-1]`` is
``|A_hat[l-1]|^2 / lambda_d[l-1]``, the previous frame's estimated clean amplitude over its
noise PSD; the first frame uses ``xi = max(gamma - 1, xi_min)`` (no previous estimate).

Why ``gain_max = 1``: for ``gamma -> 0`` the LSA gain grows without bound (the estimated
amplitude stays finite while ``|X| -> 0``).  Those are bins where speech and noise nearly
cancel; replaying a gain > 1 on the separate components would inflate both (see
:mod:`enhancers.single.ss`).  ``alpha = 0.98`` and ``xi_min = -25 dB`` follow Cappé (1994)'s
analysis of musical noise in the decision-directed estimator.

White box: the gain mask is recorded (``trace["gain"]``, ``(n_frames, n_bins)``) and
``Result.replay`` applies it to a component (exact shadow filtering).  Batch processing is
the streaming step on the whole signal, so batch and streaming outputs agree.

References: Y. Ephraim, D. Malah, "Speech enhancement using a minimum mean-square error
short-time spectral amplitude estimator", IEEE TASSP 32(6), 1984 (EM84); "... log-spectral
amplitude estimator", IEEE TASSP 33(2), 1985 (EM85); O. Cappé, IEEE TSAP 2(2), 1994.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.special import exp1

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from enhancers.core.filterbank import FilterBank, FilterBankState
from enhancers.single.noise_tracking import (
    MS2001Config,
    MS2001State,
    check_ms2001_fields,
    ms2001_init,
    ms2001_step,
)
from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_int, check_range

__all__ = ["MmseLsa", "dd_prior_snr", "lsa_gain"]

_TINY = 1e-300
_V_MIN = 1e-12  # E1(1e-12) = 27: keeps exp(E1/2) finite before the gain_max cap


def lsa_gain(xi: np.ndarray, gamma: np.ndarray, *, gain_max: float = 1.0) -> np.ndarray:
    """Ephraim & Malah (1985) LSA gain ``min(xi / (1 + xi) exp(0.5 E1(xi gamma / (1 + xi))), gain_max)``.

    Parameters
    ----------
    xi, gamma : ndarray (broadcastable)
        A-priori and a-posteriori SNR (linear power ratios, >= 0).
    gain_max : float
        Upper limit of the gain (the unbounded rule grows as ``gamma -> 0``).

    Example
    -------
    >>> float(lsa_gain(np.array(1.0), np.array(2.0)).round(4))
    0.558
    """
    xi = np.asarray(xi, dtype=float)
    v = np.maximum(xi * np.asarray(gamma, dtype=float) / (1.0 + xi), _V_MIN)
    return np.minimum(xi / (1.0 + xi) * np.exp(0.5 * exp1(v)), gain_max)


def dd_prior_snr(gamma: np.ndarray, prev: np.ndarray | None, *, alpha: float, xi_min: float) -> np.ndarray:
    """Decision-directed a-priori SNR (EM84 eq. 51), floored at ``xi_min``.

    ``prev`` is ``G[l-1]^2 gamma[l-1]`` (previous frame's clean amplitude over noise PSD),
    or None for the first frame, which then uses ``max(gamma - 1, xi_min)``.
    """
    ml = np.maximum(gamma - 1.0, 0.0)
    xi = ml if prev is None else alpha * prev + (1.0 - alpha) * ml
    return np.maximum(xi, xi_min)


@dataclass
class _LsaState:
    fb: FilterBankState
    tracker: MS2001State
    fs: int
    prev: np.ndarray | None = None  # G^2 gamma of the last frame, (n_bins,)


@functools.lru_cache(maxsize=32)
def _filterbank(frame_len: int, hop: int, window: str) -> FilterBank:
    return FilterBank(frame_len=frame_len, hop=hop, window=window)


class MmseLsa(Enhancer):
    """MMSE log-spectral amplitude (Ephraim & Malah 1985), decision-directed, Martin 2001 noise PSD.

    One channel in and out (in a 2-mic sweep the runner feeds the reference mic, as for
    ``ss``).  ``trace``: ``"gain"`` (``G``), ``"prior_snr"`` (``xi``) and ``"noise_psd"``
    (``Pn``, periodogram units), all ``(n_frames, n_bins)``, ``n_frames = n // hop``.
    Latency ``frame_len - 1`` samples.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((1, 16000))
    >>> MmseLsa().process(x, 16000).output.shape
    (1, 16000)
    """

    name: ClassVar[str] = "mmse-lsa"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "MMSE log-spectral amplitude (Ephraim-Malah 1985), decision-directed, Martin 2001 noise"

    @dataclass(frozen=True)
    class Params(Params):
        frame_len: int = 256
        hop: int = 128
        window: str = "hamming"
        alpha: float = 0.98
        xi_min_db: float = -25.0
        gain_max: float = 1.0
        # Noise tracker constants (seconds), VOICEBOX estnoisem defaults as in ss-ms2001.
        taca: float = MS2001Config.taca
        tamax: float = MS2001Config.tamax
        taminh: float = MS2001Config.taminh
        tpfall: float = MS2001Config.tpfall
        tbmax: float = MS2001Config.tbmax
        qeqmin: float = MS2001Config.qeqmin
        qeqmax: float = MS2001Config.qeqmax
        av: float = MS2001Config.av
        td: float = MS2001Config.td
        nu: int = MS2001Config.nu

        def __post_init__(self):
            n = check_int("frame_len", self.frame_len, minimum=16)
            check_int("hop", self.hop, minimum=1, maximum=n)
            if n % self.hop:
                raise ParameterError("hop", self.hop, f"a divisor of frame_len={n}")
            FilterBank(frame_len=self.frame_len, hop=self.hop, window=self.window)  # validates window
            check_range("alpha", self.alpha, 0.0, 1.0, hi_open=True)
            check_finite_number("xi_min_db", self.xi_min_db)
            check_range("xi_min_db", self.xi_min_db, -100.0, 20.0)
            check_range("gain_max", self.gain_max, 1.0, 1e3)
            check_ms2001_fields(self)

        @property
        def xi_min(self) -> float:
            return 10.0 ** (self.xi_min_db / 10.0)

    @functools.cached_property
    def filterbank(self) -> FilterBank:  # params are frozen (cached: read per block)
        p = self.params
        return _filterbank(p.frame_len, p.hop, p.window)

    @functools.cached_property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1, streaming=True, latency_samples=self.params.frame_len - 1)

    def config(self, fs: int) -> MS2001Config:
        """Tracker constants at ``fs`` (hop in seconds = ``hop / fs``)."""
        return _tracker_config(self.params, fs)

    # -- one step: analysis, tracker, gain per frame, synthesis ---------------------------
    def _init_state(self, fs: int) -> _LsaState:
        return _LsaState(fb=self.filterbank.init_state(1), tracker=ms2001_init(), fs=fs)

    def _step(self, block: np.ndarray, state: _LsaState):
        p = self.params
        fb = self.filterbank
        X, fbs = fb.analysis_step(block, state.fb)
        S = X[0].real ** 2 + X[0].imag ** 2
        _, Pn, tracker = ms2001_step(S, state.tracker, self.config(state.fs))
        gamma = S / np.maximum(Pn, _TINY)
        G = np.empty_like(S)
        xi = np.empty_like(S)
        prev = state.prev
        for f in range(S.shape[0]):  # the decision-directed recursion runs over frames
            xi[f] = dd_prior_snr(gamma[f], prev, alpha=p.alpha, xi_min=p.xi_min)
            G[f] = lsa_gain(xi[f], gamma[f], gain_max=p.gain_max)
            prev = G[f] ** 2 * gamma[f]
        out, fbs = fb.synthesis_step(G[None] * X, block.shape[-1], fbs)
        new = _LsaState(fb=fbs, tracker=tracker, fs=state.fs, prev=None if prev is None else prev.copy())
        return out, new, G, xi, Pn

    def _process_block(self, block: np.ndarray, state: _LsaState):
        out, new, *_ = self._step(block, state)
        return out, new

    def _process(self, x: np.ndarray, fs: int) -> Result:
        out, _, G, xi, Pn = self._step(x, self._init_state(fs))
        fb = self.filterbank
        n = x.shape[-1]
        gain = G.copy()
        gain.setflags(write=False)

        def replay(component) -> np.ndarray:
            comp = check_component(component, (1, n))
            return fb.synthesize(gain[None] * fb.analyze(comp), n)

        return Result(output=out, trace={"gain": gain, "prior_snr": xi, "noise_psd": Pn}, _replay=replay)


@functools.lru_cache(maxsize=32)
def _tracker_config(params: MmseLsa.Params, fs: int) -> MS2001Config:
    names = {f.name for f in dataclasses.fields(MS2001Config)} & set(params.to_dict())
    return MS2001Config(frame_step_s=params.hop / fs, **{k: getattr(params, k) for k in names})
