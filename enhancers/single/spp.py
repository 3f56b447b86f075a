"""Speech presence probability and the unbiased MMSE noise PSD estimator (Gerkmann & Hendriks 2012).

A pure step ``(P, sigma2, state) = spp_step(S, state, config)`` on a run of periodogram frames
``S = |Y|^2`` (``(n_frames, n_bins)``), vectorised over bins, looping over frames (the recursion
is nonlinear).  Batch is the same step on every frame at once, so streaming equals batch for any
split of the frames.  Per frame ``l`` and bin ``k``, with ``sigma2`` the previous frame's noise
PSD estimate::

    P     = 1 / (1 + P(H0)/P(H1) (1 + xi_H1) exp(-S / sigma2 * xi_H1 / (1 + xi_H1)))
                                              a-posteriori speech presence (fixed priors, fixed xi_H1)
    Pbar  = a_p Pbar + (1 - a_p) P;  P = min(P, p_cap) where Pbar > p_cap     stagnation guard
    E[|N|^2 | Y] = (1 - P) S + P sigma2                                       MMSE noise periodogram
    sigma2 = a_n sigma2 + (1 - a_n) E[|N|^2 | Y]                              recursive smoothing

Parameters (:class:`SppConfig`), each the paper's default:

* ``prior_h1 = 0.5``: fixed prior speech presence probability P(H1) (Gerkmann & Hendriks 2012,
  section III: a fixed prior avoids the feedback of an estimated one);
* ``xi_h1_db = 15``: fixed a-priori SNR under speech presence (same section: the value that
  minimises the total error probability for their frame set-up);
* ``tau_noise_s = 0.0717``: time constant of the noise PSD smoothing, from the paper's
  ``alpha_pow = 0.8`` per frame at its 16 ms frame advance (32 ms frames, 50 % overlap):
  ``tau = -T / ln(alpha) = -0.016 / ln 0.8 = 71.7 ms``;
* ``tau_spp_s = 0.152``: time constant of the stagnation guard's SPP smoother, from the paper's
  0.9 per frame at the same advance (``-0.016 / ln 0.9 = 151.9 ms``);
* ``p_cap = 0.99``: the guard's threshold and cap (the paper's 0.99).

A different frame advance ``T`` (the project's 8 ms hop) keeps the time constants:
``alpha = exp(-T / tau)`` (:meth:`SppConfig.alphas`), e.g. ``0.8 -> 0.894`` at 8 ms.

The first frame initialises ``sigma2`` with its own periodogram (a causal start; the paper's
MATLAB code averages the first five frames, which would need look-ahead).  Every division is
floored, so silence gives ``P = 1 / (1 + (1 + xi_H1) P(H0)/P(H1))`` and ``sigma2 = 0``, never NaN.

Accuracy in noise alone: at the true PSD one update's expectation is
``E[(1 - P) x + P] sigma2 = 0.878 sigma2`` (``x = |Y|^2 / sigma2 ~ Exp(1)``, mean SPP 0.104: the
closed-form integrals ``tests/test_spp.py`` checks); the recursion settles lower, at -1.0 dB
(-0.9 .. -1.2 dB over bins) with a mean SPP of 0.15, in 30 s of white noise through the
project's filter bank (16 ms Hamming, 8 ms hop, 16 kHz).  A tone 30 dB above the noise has
SPP >= 0.99 in its bin from its onset until the guard lets the estimate rise (``tests/test_spp.py``).

Reference: T. Gerkmann, R. C. Hendriks, "Unbiased MMSE-based noise power estimation with low
complexity and low tracking delay", IEEE TASLP 20(4), 1383-1393, 2012.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from enhancers.kernels.noise_stats import spp_frames
from scenesim.validate import check_finite_number, check_positive, check_range

__all__ = ["SppConfig", "SppState", "spp_init", "spp_posterior", "spp_step"]

_TINY = 1e-300
_EXP_MAX = 700.0  # exp() overflows float64 above ~709


@dataclass(frozen=True)
class SppConfig:
    """Constants of :func:`spp_step` (defaults: Gerkmann & Hendriks 2012; see module docstring).

    Parameters
    ----------
    hop_s : float
        Frame advance in seconds (the filter bank's hop / fs), used to turn the time constants
        into per-frame factors.
    prior_h1 : float
        Fixed prior speech presence probability, in (0, 1).
    xi_h1_db : float
        Fixed a-priori SNR under speech presence, dB.
    tau_noise_s, tau_spp_s : float
        Time constants (s) of the noise PSD and the guard's SPP smoothers.
    p_cap : float
        Stagnation guard threshold and cap, in (0, 1].

    >>> [round(a, 3) for a in SppConfig(hop_s=0.016).alphas()]
    [0.8, 0.9]
    >>> [round(a, 3) for a in SppConfig(hop_s=0.008).alphas()]
    [0.894, 0.949]
    """

    hop_s: float = 0.008
    prior_h1: float = 0.5
    xi_h1_db: float = 15.0
    tau_noise_s: float = -0.016 / math.log(0.8)
    tau_spp_s: float = -0.016 / math.log(0.9)
    p_cap: float = 0.99

    def __post_init__(self):
        check_positive("hop_s", self.hop_s)
        check_range("prior_h1", self.prior_h1, 0.0, 1.0, lo_open=True, hi_open=True)
        check_finite_number("xi_h1_db", self.xi_h1_db)
        check_positive("tau_noise_s", self.tau_noise_s)
        check_positive("tau_spp_s", self.tau_spp_s)
        check_range("p_cap", self.p_cap, 0.0, 1.0, lo_open=True)

    def alphas(self) -> tuple[float, float]:
        """Per-frame smoothing factors ``(a_n, a_p) = exp(-hop_s / tau)`` of the noise PSD and the SPP."""
        return math.exp(-self.hop_s / self.tau_noise_s), math.exp(-self.hop_s / self.tau_spp_s)


@dataclass(frozen=True)
class SppState:
    """State of :func:`spp_step`: the last noise PSD ``sigma2`` and smoothed SPP ``p_bar`` (``(n_bins,)``);
    ``sigma2`` is None before the first frame."""

    sigma2: np.ndarray | None
    p_bar: np.ndarray


def spp_init(n_bins: int) -> SppState:
    """Fresh state (no frame seen; the guard's smoothed SPP starts at 0)."""
    return SppState(sigma2=None, p_bar=np.zeros(n_bins))


def spp_posterior(snr_post, *, xi, prior_odds):
    """``1 / (1 + prior_odds (1 + xi) exp(-snr_post xi / (1 + xi)))``: the Gaussian-model SPP.

    ``snr_post`` is ``|Y|^2 / sigma2`` (any shape), ``xi`` the a-priori SNR under speech (linear,
    scalar or broadcastable), ``prior_odds = P(H0) / P(H1)``.  Written with one ``exp`` of a
    clipped exponent, so it never overflows.

    >>> float(spp_posterior(0.0, xi=10 ** 1.5, prior_odds=1.0)) < 0.03
    True
    >>> float(spp_posterior(1000.0, xi=10 ** 1.5, prior_odds=1.0))
    1.0
    """
    xi = np.asarray(xi, dtype=float)
    expo = np.log(prior_odds * (1.0 + xi)) - np.asarray(snr_post, dtype=float) * (xi / (1.0 + xi))
    return 1.0 / (1.0 + np.exp(np.minimum(expo, _EXP_MAX)))


def spp_step(S: np.ndarray, state: SppState, config: SppConfig, *,
             kernel: bool = False) -> tuple[np.ndarray, np.ndarray, SppState]:
    """SPP and noise PSD of the frames ``S`` (``(n_frames, n_bins)`` periodograms ``|Y|^2``).

    Returns ``(P, sigma2, state)``: ``P`` the (guarded) SPP of each frame and ``sigma2`` the noise
    PSD after each frame's update, both ``(n_frames, n_bins)``; ``state`` a new state.  ``kernel``: the
    compiled copy :func:`enhancers.kernels.noise_stats.spp_frames` (equal to rounding), else this
    numpy reference.

    >>> import numpy as np
    >>> S = np.random.default_rng(0).exponential(2.0, size=(4000, 3))
    >>> P, sigma2, _ = spp_step(S, spp_init(3), SppConfig())
    >>> bool(np.all(np.abs(10 * np.log10(sigma2[500:].mean(axis=0) / 2.0)) < 1.5))
    True
    """
    S = np.asarray(S, dtype=float)
    a_n, a_p = config.alphas()
    xi = 10.0 ** (config.xi_h1_db / 10.0)
    odds = (1.0 - config.prior_h1) / config.prior_h1
    if kernel and S.shape[0]:
        sigma2 = (S[0] if state.sigma2 is None else state.sigma2).astype(float)  # a copy: updated in place
        p_bar = state.p_bar.astype(float)
        P, out = spp_frames(np.ascontiguousarray(S), sigma2, p_bar, a_n, a_p, xi, odds, float(config.p_cap))
        return P, out, SppState(sigma2=sigma2, p_bar=p_bar)
    P = np.empty_like(S)
    out = np.empty_like(S)
    sigma2, p_bar = state.sigma2, state.p_bar
    for i in range(S.shape[0]):
        s = S[i]
        if sigma2 is None:
            sigma2 = s.copy()
        p = spp_posterior(s / np.maximum(sigma2, _TINY), xi=xi, prior_odds=odds)
        p_bar = a_p * p_bar + (1.0 - a_p) * p
        p = np.where(p_bar > config.p_cap, np.minimum(p, config.p_cap), p)
        sigma2 = a_n * sigma2 + (1.0 - a_n) * ((1.0 - p) * s + p * sigma2)
        P[i], out[i] = p, sigma2
    return P, out, SppState(sigma2=None if sigma2 is None else sigma2.copy(), p_bar=p_bar.copy())
