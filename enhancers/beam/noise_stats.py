"""Noise statistics of a microphone pair: speech presence probability and 2x2 covariances per bin.

A stage other enhancers compose: a pure step ``(stats, state) = noise_stats_step(X, state, config)``
on the STFT frames ``X`` (``(2, n_frames, n_bins)``, reference mic first) with an explicit state,
vectorised over bins (closed-form 2x2 algebra, no per-bin loop), looping over frames because the
speech presence probability (SPP) of a frame depends on the noise statistics of the frame before.
Batch is the same step on every frame, so streaming equals batch for any split of the frames.

Per frame ``l`` and bin (``y`` the ``(2,)`` STFT vector)::

    Phi_yy[l] = R_yy[l] / N_yy[l],  R_yy[l] = a_y R_yy[l-1] + (1 - a_y) y y^H,
                                    N_yy[l] = a_y N_yy[l-1] + (1 - a_y)          every frame
                                    (noisy_weight="spp": a_y -> a_y + (1 - a_y)(1 - p[l]), weight p)
    p[l]      = SPP (below)
    a~        = a_v + (1 - a_v) p[l]                              Souden et al. 2010, eq. (13)-(14)
    Phi_vv[l] = R_vv[l] / N_vv[l],  R_vv[l] = a~ R_vv[l-1] + (1 - a~) y y^H,
                                    N_vv[l] = a~ N_vv[l-1] + (1 - a~)            weight 1 - p

The normalisers ``N`` (zero at the start) are the bias correction of a recursive average started
from zero: the first frame gets weight 1, and ``N -> 1`` once the average has filled (without them
the early estimates are scaled down by ``1 - a^l``).  The SPP, by ``config.spp``:

* ``"single"``: Gerkmann & Hendriks (2012) on the reference mic, :func:`enhancers.single.spp.spp_step`;
* ``"mean"``: the same tracker on the pair's mean periodogram ``(|Y_0|^2 + |Y_1|^2) / 2``
  (:func:`spp_periodogram`).  Its weights are symmetric in the two mics, so the weighted average's
  bias in noise alone is a common scale of both diagonal entries (below) -- to which the GEVD RTF,
  the MVDR and the EB's closed-form beta are invariant, and which leaves the calibration's
  ``|r| = sqrt(Phi_11 / Phi_00)`` unbiased -- where ``"single"`` biases the reference mic's entry
  alone.  For a coherent field (low frequency, a point source) the mean is the one-mic periodogram
  and the tracker's exponential model holds; for incoherent noise it has less variance than that
  model assumes, so fewer noise-only cells read as speech (mean ``p`` 0.10 against 0.15);
* ``"multi"``: Souden, Chen, Benesty & Affes (2010), Gaussian model of the pair::

      p  = [1 + q / (1 - q) (1 + xi) exp(-beta / (1 + xi))]^-1
      xi = tr(Phi_vv^-1 Phi_xx),  beta = y^H Phi_vv^-1 Phi_xx Phi_vv^-1 y,
      Phi_xx = PSD part of (Phi_yy[l] - Phi_vv[l-1])        (negative eigenvalue clipped to 0)

  with ``q`` the fixed prior speech absence probability (0.5, the fixed prior of Gerkmann &
  Hendriks) and the same stagnation guard as the single-channel SPP (smoothed SPP above 0.99 caps
  ``p`` at 0.99).  Until the noise average holds about one time constant of frames (its normaliser
  ``N_vv >= 1 - 1/e``) ``p`` is the prior ``1 - q``: measured against the rank-1 ``Phi_vv`` of the
  first frames, every later frame looks like speech (mean ``p`` 0.93 over the first second of white
  noise, 5 s to settle).  In noise alone ``xi -> 0`` and ``p -> 1 - q``: the noise statistics then update
  at half their rate (measured mean ``p`` in noise alone 0.54, ``tests/test_noise_stats.py``).

``noisy_weight="spp"`` (single-channel SPPs) updates the noisy average with the weight ``p``, the
speech-present frames, as MWF implementations update ``R_yy`` only where a voice activity detector
fires and ``R_vv`` only where it does not (Doclo, Spriet, Wouters & Moonen 2007; Serizel, Moonen,
van Dijk & Wouters 2014): through a pause the talker stays in ``Phi_yy``, so the GEVD's excess
``Phi_yy - Phi_vv`` stays the talker's instead of decaying towards whatever the noise did last
(``tests/test_noise_stats.py``: a tone 30 dB over the noise is still 27 dB over it 3 s into a pause,
against 19 dB for the every-frame average).  The multichannel SPP reads the every-frame average, so it
keeps ``"every"``.

The step also returns the noise average's normaliser ``N_vv`` per frame (``NoiseStats.n_vv``), so a
caller can give the unfilled mass ``1 - N_vv`` to a prior (``eb-spp``'s start-up prior).  With
``kernel=True`` and the single-channel tracker (``"single"``, ``"mean"``) the frame loops run compiled
(:mod:`enhancers.kernels.noise_stats`; this module's numpy loop stays the reference, equal to rounding,
``tests/test_noise_stats_kernel.py``).

Parameters (:class:`NoiseStatsConfig`): the SPP's (:class:`enhancers.single.spp.SppConfig`), ``q``, and
the time constants of the two averages ``tau_noisy_s`` / ``tau_noise_s`` (per-frame factors
``a = exp(-hop_s / tau)``), defaults 1 s / 0.5 s and ``spp="single"``: the SPP and the noisy average's
time constant that served ``mvdr`` best on a dev split (see :mod:`enhancers.beam.mvdr`).

Bias in noise alone: frames with a high SPP are louder than average, so the (1 - p)-weighted
average sits below the noise covariance.  Measured on independent complex white noise
(``E[y y^H] = 2 I``, seed 0, 4 bins, frames 2000-20000 of 20000): ``"multi"`` -0.15 / -0.10 dB on
the two diagonal entries (mean p 0.51); ``"mean"`` -0.33 / -0.29 dB (mean p 0.10); ``"single"``
-1.04 dB on the reference mic and +0.04 dB on the other (mean p 0.15).  No correction is applied (the literature gives
none for the weighted covariance).  Every division is floored; silence gives zero matrices and
``p = 1 - q`` (multi) or the single-channel SPP's silence value, never NaN.

References: M. Souden, J. Chen, J. Benesty, S. Affes, "Gaussian model-based multichannel speech
presence probability", IEEE TASLP 18(5), 1072-1077, 2010; R. Serizel, M. Moonen, B. van Dijk, J. Wouters,
"Low-rank approximation based multichannel Wiener filter algorithms for noise reduction with application
in cochlear implants", IEEE/ACM TASLP 22(4), 2014; M. Souden, J. Chen, J. Benesty, S. Affes,
"An integrated solution for online multichannel noise tracking and reduction", IEEE TASLP 19(7),
2159-2169, 2011; T. Gerkmann, R. C. Hendriks, IEEE TASLP 20(4), 2012.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from enhancers.kernels.noise_stats import weighted_cov_frames
from enhancers.single.spp import SppConfig, SppState, spp_init, spp_step
from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_positive, check_range

__all__ = ["NoiseStats", "NoiseStatsConfig", "NoiseStatsState", "SPP_METHODS", "hermitian_inv", "loaded",
           "multichannel_spp", "noise_stats_init", "noise_stats_step", "outer", "psd_part", "spp_periodogram"]

SPP_METHODS = ("single", "mean", "multi")
NOISY_WEIGHTS = ("every", "spp")
_SINGLE_CHANNEL = ("single", "mean")  # the Gerkmann & Hendriks tracker, on one periodogram per bin
_TINY = 1e-300
_FLOOR = 1e-20  # absolute floor of the diagonal loading: far below any audio's STFT power
_EXP_MAX = 700.0
_SETTLED = 1.0 - math.exp(-1.0)  # the noise average's normaliser once it holds ~one time constant


# -- closed-form 2x2 Hermitian algebra (vectorised over leading axes, matrices (..., 2, 2)) ----------
def outer(y: np.ndarray) -> np.ndarray:
    """``y y^H`` of ``(..., 2)`` vectors: ``(..., 2, 2)``."""
    return y[..., :, None] * np.conj(y[..., None, :])


def loaded(A: np.ndarray, fraction: float) -> np.ndarray:
    """``A + delta I`` with ``delta = fraction tr(A) / 2 + 1e-20`` (diagonal loading relative to the mean
    diagonal; the absolute floor keeps a zero matrix invertible)."""
    delta = fraction * 0.5 * np.real(A[..., 0, 0] + A[..., 1, 1]) + _FLOOR
    out = A.copy()
    out[..., 0, 0] += delta
    out[..., 1, 1] += delta
    return out


def hermitian_inv(A: np.ndarray) -> np.ndarray:
    """Inverse of Hermitian 2x2 matrices by the adjugate, ``[[d, -b], [-b*, a]] / (a d - |b|^2)``
    (determinant floored at 1e-300: pass loaded matrices).

    >>> import numpy as np
    >>> A = np.array([[2.0, 1j], [-1j, 3.0]])
    >>> bool(np.allclose(hermitian_inv(A) @ A, np.eye(2)))
    True
    """
    a, d, b = np.real(A[..., 0, 0]), np.real(A[..., 1, 1]), A[..., 0, 1]
    det = np.maximum(a * d - np.abs(b) ** 2, _TINY)
    out = np.empty(A.shape, dtype=complex)
    out[..., 0, 0], out[..., 1, 1] = d / det, a / det
    out[..., 0, 1], out[..., 1, 0] = -b / det, -np.conj(b) / det
    return out


def psd_part(A: np.ndarray) -> np.ndarray:
    """Hermitian 2x2 ``A`` with its negative eigenvalues set to 0 (closed form).

    Eigenvalues ``m +- r``, ``m = tr/2``, ``r = sqrt(((a - d)/2)^2 + |b|^2)``.  Both >= 0: ``A``;
    both <= 0: 0; else ``lam+ (A - lam- I) / (2 r)`` (``lam+`` times its eigenprojector).

    >>> import numpy as np
    >>> psd_part(np.diag([2.0, -1.0]).astype(complex)).real.tolist()
    [[2.0, 0.0], [0.0, 0.0]]
    """
    a, d, b = np.real(A[..., 0, 0]), np.real(A[..., 1, 1]), A[..., 0, 1]
    m = 0.5 * (a + d)
    r = np.sqrt((0.5 * (a - d)) ** 2 + np.abs(b) ** 2)
    lo, hi = m - r, m + r
    shifted = A.copy()
    shifted[..., 0, 0] -= lo
    shifted[..., 1, 1] -= lo
    part = (hi / np.maximum(2.0 * r, _TINY))[..., None, None] * shifted
    keep = (lo >= 0.0)[..., None, None]
    zero = (hi <= 0.0)[..., None, None]
    return np.where(keep, A, np.where(zero, 0.0, part))


def multichannel_spp(y: np.ndarray, Phi_yy: np.ndarray, Phi_vv: np.ndarray, *, q: float,
                     loading: float = 1e-6) -> np.ndarray:
    """Souden et al. (2010) SPP of the frame vectors ``y`` (``(..., 2)``) given the noisy and noise
    covariances (``(..., 2, 2)``); ``q`` the prior speech absence probability.  Returns ``(...,)``.

    ``Phi_vv`` is loaded by ``loading`` (relative) before its inverse.

    >>> import numpy as np
    >>> V = np.eye(2, dtype=complex)
    >>> float(multichannel_spp(np.zeros(2), V, V, q=0.5))   # no speech in the statistics: the prior
    0.5
    """
    Vi = hermitian_inv(loaded(Phi_vv, loading))
    Xx = psd_part(Phi_yy - Phi_vv)
    M = Vi @ Xx
    xi = np.maximum(np.real(M[..., 0, 0] + M[..., 1, 1]), 0.0)
    z = np.einsum("...ij,...j->...i", Vi, y)
    beta = np.maximum(np.real(np.einsum("...i,...ij,...j->...", np.conj(z), Xx, z)), 0.0)
    expo = math.log(q / (1.0 - q)) + np.log1p(xi) - beta / (1.0 + xi)
    return 1.0 / (1.0 + np.exp(np.minimum(expo, _EXP_MAX)))


# -- the stage -------------------------------------------------------------------------------------
def spp_periodogram(Y: np.ndarray, spp: str) -> np.ndarray:
    """The periodogram the single-channel SPP tracks: ``|Y_0|^2`` (``"single"``) or the pair's mean
    ``(|Y_0|^2 + |Y_1|^2) / 2`` (``"mean"``); ``Y`` is ``(n_frames, n_bins, 2)``, the result ``(n_frames, n_bins)``.

    >>> import numpy as np
    >>> Y = np.array([[[1.0, 3.0]]])
    >>> spp_periodogram(Y, "single").tolist(), spp_periodogram(Y, "mean").tolist()
    ([[1.0]], [[5.0]])
    """
    if spp == "mean":
        return 0.5 * (np.abs(Y[..., 0]) ** 2 + np.abs(Y[..., 1]) ** 2)
    return np.abs(Y[..., 0]) ** 2


def check_stats_fields(obj) -> None:
    """Check the stage's fields an object carries (``spp``, ``tau_noise_s``, ``prior_absence`` and, where
    present, ``tau_noisy_s``): the one check shared by the config and the enhancers' Params.

    >>> from types import SimpleNamespace
    >>> check_stats_fields(SimpleNamespace(spp="single", tau_noise_s=0.5, prior_absence=0.5))
    >>> check_stats_fields(SimpleNamespace(spp="single", tau_noise_s="x", prior_absence=0.5))
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter tau_noise_s='x' is invalid: expected a finite real number.
    """
    check_choice("spp", obj.spp, SPP_METHODS)
    for name in ("tau_noisy_s", "tau_noise_s"):
        if hasattr(obj, name):  # time constants: above 10 min nothing would ever be learned
            check_range(name, getattr(obj, name), 0.0, 600.0, lo_open=True)
    check_range("prior_absence", obj.prior_absence, 0.0, 1.0, lo_open=True, hi_open=True)


@dataclass(frozen=True)
class NoiseStatsConfig:
    """Constants of :func:`noise_stats_step` (see module docstring).

    Parameters
    ----------
    hop_s : float
        Frame advance, seconds (the filter bank's hop / fs).
    spp : {"single", "mean", "multi"}
        Gerkmann & Hendriks on the reference mic or on the pair's mean periodogram, or Souden et al.'s
        multichannel SPP.
    tau_noisy_s, tau_noise_s : float
        Time constants (s) of the noisy and the noise covariance averages.
    noisy_weight : {"every", "spp"}
        The noisy average's update weight: every frame, or ``p`` (speech-present frames; single-channel SPPs only).
    prior_absence : float
        ``q`` of the multichannel SPP, in (0, 1).
    spp_config : SppConfig or None
        The single-channel SPP's constants (also the stagnation guard of both); None: its defaults at ``hop_s``.

    >>> c = NoiseStatsConfig(hop_s=0.008)
    >>> [round(a, 3) for a in c.alphas()]
    [0.992, 0.984]
    """

    hop_s: float = 0.008
    spp: str = "single"
    tau_noisy_s: float = 1.0
    tau_noise_s: float = 0.5
    prior_absence: float = 0.5
    noisy_weight: str = "every"
    spp_config: SppConfig | None = field(default=None)

    def __post_init__(self):
        check_positive("hop_s", self.hop_s)
        check_stats_fields(self)
        check_choice("noisy_weight", self.noisy_weight, NOISY_WEIGHTS)
        if self.noisy_weight == "spp" and self.spp not in _SINGLE_CHANNEL:
            raise ParameterError("noisy_weight", self.noisy_weight,
                                 f'"every" with spp={self.spp!r} (its SPP reads the every-frame noisy average)')
        if self.spp_config is None:
            object.__setattr__(self, "spp_config", SppConfig(hop_s=self.hop_s))

    def alphas(self) -> tuple[float, float]:
        """Per-frame factors ``(a_y, a_v)`` of the noisy and noise averages."""
        return math.exp(-self.hop_s / self.tau_noisy_s), math.exp(-self.hop_s / self.tau_noise_s)


@dataclass(frozen=True)
class NoiseStatsState:
    """State of :func:`noise_stats_step` (never mutated; the step returns a new one).

    ``r_yy``, ``r_vv``: ``(n_bins, 2, 2)`` recursive sums; ``n_yy``, ``n_vv``: ``(n_bins,)`` their
    normalisers; ``spp``: the single-channel tracker's state; ``p_bar``: the multichannel SPP's guard.
    """

    r_yy: np.ndarray
    n_yy: np.ndarray
    r_vv: np.ndarray
    n_vv: np.ndarray
    spp: SppState
    p_bar: np.ndarray


class NoiseStats(NamedTuple):
    """What :func:`noise_stats_step` returns per frame: ``yy``, ``vv`` ``(n_frames, n_bins, 2, 2)``
    (after the frame's update), ``p`` ``(n_frames, n_bins)`` (the SPP that weighted it) and ``n_vv``
    ``(n_frames, n_bins)``, the noise average's normaliser (the weight of the frames it holds, 0 at the
    start, -> 1 once filled)."""

    yy: np.ndarray
    vv: np.ndarray
    p: np.ndarray
    n_vv: np.ndarray


def noise_stats_init(n_bins: int) -> NoiseStatsState:
    """Fresh state: empty averages (normalisers 0), the SPP trackers at their start."""
    z = np.zeros((n_bins, 2, 2), dtype=complex)
    return NoiseStatsState(r_yy=z, n_yy=np.zeros(n_bins), r_vv=z, n_vv=np.zeros(n_bins),
                           spp=spp_init(n_bins), p_bar=np.zeros(n_bins))


def _average(r, n, a, yy):
    """One update of a normalised recursive average: ``(R, N, R / N)``; ``a`` scalar or ``(n_bins,)``."""
    a = np.asarray(a, dtype=float)
    r = a[..., None, None] * r + (1.0 - a)[..., None, None] * yy
    n = a * n + (1.0 - a)
    return r, n, r / np.maximum(n, _TINY)[..., None, None]


def noise_stats_step(X: np.ndarray, state: NoiseStatsState, config: NoiseStatsConfig, *,
                     kernel: bool = False, noisy: bool = True) -> tuple[NoiseStats, NoiseStatsState]:
    """Covariances and SPP of the frames ``X`` (``(2, n_frames, n_bins)`` complex, reference mic first).

    ``kernel``: with ``spp="single"`` or ``"mean"``, the compiled copies of the frame loops
    (:mod:`enhancers.kernels.noise_stats`, equal to this numpy reference to rounding); the
    multichannel SPP always runs here.  ``noisy=False`` (compiled single-channel path only): a caller
    that never reads the noisy covariance skips it -- ``NoiseStats.yy`` then has no frames and the
    state's noisy average stays where it was.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.standard_normal((2, 2000, 3)) + 1j * rng.standard_normal((2, 2000, 3))
    >>> stats, _ = noise_stats_step(X, noise_stats_init(3), NoiseStatsConfig(spp="multi"))
    >>> v = stats.vv[500:].mean(axis=(0, 1)).real   # E[y y^H] = 2 I, less the SPP weights' bias
    >>> bool(abs(v[0, 1]) < 0.05 and abs(10 * np.log10(v[0, 0] / 2.0)) < 1.0)
    True
    """
    Y = np.moveaxis(np.asarray(X), 0, -1)  # (F, K, 2)
    F, K = Y.shape[0], Y.shape[1]
    a_y, a_v = config.alphas()
    sc = config.spp_config
    s_state = state.spp
    if config.spp in _SINGLE_CHANNEL:
        P_all, _, s_state = spp_step(spp_periodogram(Y, config.spp), state.spp, sc, kernel=kernel)
        if kernel and config.noisy_weight == "every":
            return _single_compiled(Y, P_all, state, s_state, config, noisy)
    a_p = sc.alphas()[1]
    yy_out = np.empty((F, K, 2, 2), dtype=complex)
    vv_out = np.empty((F, K, 2, 2), dtype=complex)
    p_out = np.empty((F, K))
    nv_out = np.empty((F, K))
    r_yy, n_yy, r_vv, n_vv, p_bar = state.r_yy, state.n_yy, state.r_vv, state.n_vv, state.p_bar
    q = config.prior_absence
    gated = config.noisy_weight == "spp"
    for i in range(F):
        yyH = outer(Y[i])
        a_i = a_y + (1.0 - a_y) * (1.0 - P_all[i]) if gated else np.full(K, a_y)
        r_yy, n_yy, Phi_yy = _average(r_yy, n_yy, a_i, yyH)
        if config.spp in _SINGLE_CHANNEL:
            p = P_all[i]
        else:
            seen = n_vv >= _SETTLED
            Phi_vv = r_vv / np.maximum(n_vv, _TINY)[:, None, None]
            p = np.where(seen, multichannel_spp(Y[i], Phi_yy, Phi_vv, q=q), 1.0 - q)
            p_bar = a_p * p_bar + (1.0 - a_p) * p
            p = np.where(p_bar > sc.p_cap, np.minimum(p, sc.p_cap), p)
        r_vv, n_vv, vv_out[i] = _average(r_vv, n_vv, a_v + (1.0 - a_v) * p, yyH)
        yy_out[i], p_out[i], nv_out[i] = Phi_yy, p, n_vv
    new = NoiseStatsState(r_yy=r_yy, n_yy=n_yy, r_vv=r_vv, n_vv=n_vv, spp=s_state, p_bar=p_bar)
    return NoiseStats(yy=yy_out, vv=vv_out, p=p_out, n_vv=nv_out), new


def _single_compiled(Y, P_all, state, s_state, config, noisy=True):
    """:func:`noise_stats_step`'s averages for a given SPP by the compiled loop (state arrays copied)."""
    a_y, a_v = config.alphas()
    r_yy, n_yy, r_vv, n_vv = (np.array(a, dtype=c) for a, c in ((state.r_yy, complex), (state.n_yy, float),
                                                               (state.r_vv, complex), (state.n_vv, float)))
    yy, vv, nv = weighted_cov_frames(np.ascontiguousarray(Y), np.ascontiguousarray(P_all), r_yy, n_yy, r_vv, n_vv,
                                 a_y, a_v, noisy)
    new = NoiseStatsState(r_yy=r_yy, n_yy=n_yy, r_vv=r_vv, n_vv=n_vv, spp=s_state, p_bar=state.p_bar)
    return NoiseStats(yy=yy, vv=vv, p=P_all, n_vv=nv), new
