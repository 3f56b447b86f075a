"""Adaptive two-mic MVDR and speech-distortion-weighted MWF on the noise statistics (``"mvdr"``, ``"mwf"``).

Per frame and bin, from the noisy and noise covariances of
:func:`enhancers.beam.noise_stats.noise_stats_step` (``Phi_vv`` loaded: ``V = Phi_vv + delta I``,
``delta = loading tr(Phi_vv) / 2``)::

    V^-1 Phi_yy u = lam u,  lam the largest          principal generalised eigenvector (GEVD)
    h   = V u / (e_ref^T V u)                        RTF by covariance whitening (h_ref = 1)
    w   = V^-1 h / (h^H V^-1 h)                      MVDR, distortionless for the reference mic
    Y   = w^H y

(Markovich-Golan & Gannot 2015).  For a rank-1 speech covariance ``Phi_xx = phi h h^H`` and
``Phi_yy = Phi_xx + Phi_vv``: ``lam - 1 = phi h^H Phi_vv^-1 h`` is the MVDR's output SNR, and the
speech-distortion-weighted multichannel Wiener filter (Doclo & Moonen; Spriet, Moonen & Wouters
2004) in its rank-1 form is::

    w_mu = V^-1 Phi_xx e_ref / (mu + tr(V^-1 Phi_xx)) = w_MVDR (lam - 1) / (mu + lam - 1)

``mu = 0``: the MVDR; ``mu = 1``: the MVDR followed by a single-channel Wiener post-filter;
larger ``mu`` trades speech distortion for noise reduction (:func:`sdw_mwf_weights` is the general
formula, :func:`rank1_mwf_weights` the form the enhancer uses).  The reference mic is channel 0.
``mvdr-ss`` is ``mvdr`` followed by ``ss`` (:class:`MvdrSs`).

The weights of every frame and bin are recorded (``trace["weights"]``, ``(n_frames, n_bins, 2)``,
``Y = w^H y``) and ``Result.replay`` applies them to a component's frames: a time-varying linear
operation, exact shadow filtering.  Latency ``frame_len - 1`` samples (the WOLA filter bank's).
Batch runs the streaming step on every frame, so streaming equals batch.

Two choices make the estimates of a static talker hold still (both in version 2; ``mvdr@1`` has neither):

* **Start-up prior** (``startup_prior="diffuse"``).  The noise average's unfilled mass ``1 - N_vv``
  goes to the diffuse field at the average's own level, ``V <- N V + (1 - N) L Gamma``,
  ``L = tr(V) / 2``, ``Gamma`` the coherence ``sinc(2 f d / c)`` (:func:`with_startup_prior`; the
  same conjugate prior as ``eb-spp``'s step 0).  Without it the first frames' few-frame ``Phi_vv``
  steers the GEVD, and the talker's path through them differs between Hagerman's two runs (dev
  split: the worst rows' jitter came from the first second).  ``"white"`` (``L I``) and ``"none"``
  are selectable.
* **Speech-weighted noisy average** (``noisy_weight="spp"``, :mod:`enhancers.beam.noise_stats`):
  ``Phi_yy`` learns with the weight ``p``, so through a pause the GEVD's excess stays the talker's.

Parameters (:class:`Mvdr.Params`): the filter bank's (16 ms Hamming, 50 % overlap), the noise
statistics' (``spp = "single"``, ``tau_noisy_s = 1``, ``tau_noise_s = 0.5``, ``prior_absence``,
``noisy_weight = "spp"``; :mod:`enhancers.beam.noise_stats`), ``startup_prior = "diffuse"`` and
``loading = 1e-3``: diagonal loading relative to the mean diagonal of ``Phi_vv``, a guard on the
inverse of a diffuse field's nearly singular covariance at low frequency (coherence ``sinc(2 f d / c)``
is 0.9997 at 100 Hz for 2.14 cm), not a white-noise-gain constraint.

Measured accuracy (``python -m benchmarks.studies.heldout_targets``; defaults chosen on the dev split,
figures from the test split: ``phone`` at 15-25 dB, seeds 0-9, 120 rows per data set).  Built-in data:
speech jitter <= -30 dB in 95 % of rows, worst -24.6 dB, median -38.4 dB; replay and Hagerman SNR-I
within 3 dB in 100 %; SNR-I against ``superdirective``, mean (lower 95 % bound) per noise: babble +0.02
(-0.19), factory -0.82 (-1.47), factory-hall -0.03 (-0.43), wind +13.5 (+12.9) dB.  Real recordings
(``../shared/data``, test half): jitter 89 % / worst -18.7 dB; factory -1.55 (-2.17) dB.  ``mvdr@1`` on the
same rows: 99 % / -28.3 dB and 88 % / -22.4 dB, so the two choices' dev gain is not confirmed on test.
The known weakness is impulsive directional noise (factory): the single-channel SPP takes its impacts
for speech, so the GEVD turns towards the noise source; on dev, the true RTF with the same ``Phi_vv``
gains 7.6-9.4 dB SNR-I on the 15 dB factory rows where this RTF gains 1.4-1.9 dB.

References: S. Markovich-Golan, S. Gannot, "Performance analysis of the covariance subtraction method for
relative transfer function estimation and comparison to the covariance whitening method", ICASSP 2015;
S. Doclo, A. Spriet, J. Wouters, M. Moonen, "Frequency-domain criterion for the speech distortion weighted
multichannel Wiener filter for robust noise reduction", Speech Communication 49, 2007; M. Souden, J. Benesty,
S. Affes, "On optimal frequency-domain multichannel linear filtering for noise reduction", IEEE TASLP 18(2), 2010.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.beam.noise_stats import (
    NoiseStatsConfig,
    check_stats_fields,
    hermitian_inv,
    loaded,
    noise_stats_init,
    noise_stats_step,
)
from enhancers.beam.superdirective import diffuse_coherence
from enhancers.core.base import params_with_defaults
from enhancers.core.chain import Chain
from enhancers.core.stft_stage import StftEnhancer, StftParams
from scenesim.validate import check_choice, check_range

__all__ = ["Mvdr", "MvdrSs", "MvdrSsV1", "MvdrV1", "Mwf", "MwfV1", "with_startup_prior", "gevd_rtf", "mvdr_weights", "rank1_mwf_weights", "sdw_mwf_weights"]

_TINY = 1e-300
_GEVD_LOADING = 1e-6  # relative loading of Phi_vv inside the GEVD: a guard on its inverse only


def _matvec(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", A, x)


def gevd_rtf(Phi_yy: np.ndarray, Phi_vv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RTF ``h`` (``(..., 2)``, ``h[..., 0] = 1``) and the largest generalised eigenvalue ``lam`` (``(...,)``)
    of ``(Phi_yy, Phi_vv)`` (``(..., 2, 2)``; pass ``Phi_vv`` loaded).

    ``C = Phi_vv^-1 Phi_yy``; ``lam = tr/2 + sqrt((tr/2)^2 - det)`` (real: ``C`` is similar to a
    Hermitian matrix); ``u`` the longer of ``[C01, lam - C00]`` and ``[lam - C11, C10]`` (both solve
    ``(C - lam I) u = 0``); where both vanish (``Phi_yy`` proportional to ``Phi_vv``: no direction
    stands out) ``h = e_ref``.

    >>> import numpy as np
    >>> h = np.array([1.0, np.exp(-0.5j)])
    >>> yy = 4 * np.outer(h, h.conj()) + np.eye(2)
    >>> bool(np.allclose(gevd_rtf(yy, np.eye(2))[0], h))
    True
    """
    C = hermitian_inv(Phi_vv) @ Phi_yy
    half = 0.5 * np.real(C[..., 0, 0] + C[..., 1, 1])
    det = np.real(C[..., 0, 0] * C[..., 1, 1] - C[..., 0, 1] * C[..., 1, 0])
    lam = half + np.sqrt(np.maximum(half**2 - det, 0.0))
    u1 = np.stack([C[..., 0, 1], lam - C[..., 0, 0]], axis=-1)
    u2 = np.stack([lam - C[..., 1, 1], C[..., 1, 0]], axis=-1)
    n1, n2 = np.sum(np.abs(u1) ** 2, axis=-1), np.sum(np.abs(u2) ** 2, axis=-1)
    u = np.where((n1 >= n2)[..., None], u1, u2)
    v = _matvec(Phi_vv, u)
    scale = np.maximum(np.maximum(n1, n2), _TINY) * np.real(Phi_vv[..., 0, 0] + Phi_vv[..., 1, 1])
    ok = np.abs(v[..., 0]) ** 2 > 1e-24 * np.maximum(scale, _TINY)
    h = np.where(ok[..., None], v / np.where(ok, v[..., 0], 1.0)[..., None], np.array([1.0, 0.0]))
    return h, lam


def mvdr_weights(h: np.ndarray, Phi_vv: np.ndarray) -> np.ndarray:
    """``w = Phi_vv^-1 h / (h^H Phi_vv^-1 h)`` (``(..., 2)``; pass ``Phi_vv`` loaded); ``w^H h = 1``.

    >>> import numpy as np
    >>> h = np.array([1.0, 1j])
    >>> w = mvdr_weights(h, np.array([[1.0, 0.5], [0.5, 1.0]], dtype=complex))
    >>> complex(np.round(np.vdot(w, h), 12))
    (1+0j)
    """
    g = _matvec(hermitian_inv(Phi_vv), h)
    den = np.real(np.sum(np.conj(h) * g, axis=-1))
    return g / np.maximum(den, _TINY)[..., None]


def sdw_mwf_weights(Phi_vv: np.ndarray, Phi_xx: np.ndarray, mu: float, ref: int = 0) -> np.ndarray:
    """Speech-distortion-weighted MWF ``w = Phi_vv^-1 Phi_xx e_ref / (mu + tr(Phi_vv^-1 Phi_xx))``, ``(..., 2)``.

    The rank-1 closed form (Souden, Benesty & Affes 2010, eq. 47; Doclo et al. 2007); for a rank-1
    ``Phi_xx`` it equals ``w_MVDR xi / (mu + xi)`` with ``xi = tr(Phi_vv^-1 Phi_xx)``.

    >>> import numpy as np
    >>> V, h = np.eye(2, dtype=complex), np.array([1.0, 1j])
    >>> np.round(sdw_mwf_weights(V, 2 * np.outer(h, h.conj()), mu=0.0), 12).tolist()
    [(0.5+0j), 0.5j]
    """
    M = hermitian_inv(Phi_vv) @ Phi_xx
    tr = np.real(M[..., 0, 0] + M[..., 1, 1])
    return M[..., :, ref] / np.maximum(mu + tr, _TINY)[..., None]


def rank1_mwf_weights(Phi_yy: np.ndarray, Phi_vv: np.ndarray, mu: float, *, loading: float) -> np.ndarray:
    """The enhancer's weights: GEVD RTF, MVDR, times ``(lam - 1) / (mu + lam - 1)`` (1 for ``mu = 0``).

    ``(..., 2)``; ``Phi_vv`` is loaded by ``loading`` here.  ``lam - 1`` is clipped at 0 (a noisy
    covariance below the noise's: no speech, so ``mu > 0`` passes nothing).
    """
    V = loaded(Phi_vv, loading)
    # the GEVD on the (nearly) unloaded pair: loading adds a white part that is in Phi_vv but not in
    # Phi_yy - Phi_vv, which tilts the eigenvector away from the RTF (oracle covariances, factory at
    # 0 dB: 16.8 dB SNR-I at 1e-6, 8.3 dB at 1e-3)
    h, lam = gevd_rtf(Phi_yy, loaded(Phi_vv, _GEVD_LOADING))
    w = mvdr_weights(h, V)
    if mu == 0.0:
        return w
    xi = np.maximum(lam - 1.0, 0.0)
    return w * (xi / (mu + xi))[..., None]


STARTUP_PRIORS = ("white", "diffuse", "none")


def with_startup_prior(Phi_vv: np.ndarray, n_vv: np.ndarray, shape: np.ndarray | None) -> np.ndarray:
    """``N Phi_vv + (1 - N) L shape``, ``L = tr(Phi_vv) / 2``: the noise average's unfilled mass ``1 - N``
    given to a prior field of the estimate's own level (``Phi_vv`` ``(..., K, 2, 2)``, ``n_vv`` ``(..., K)``,
    ``shape`` ``(K, 2, 2)`` with unit diagonal, or None: ``Phi_vv`` unchanged).

    >>> import numpy as np
    >>> V = np.array([[[2.0, 1.0], [1.0, 2.0]]], dtype=complex)
    >>> with_startup_prior(V, np.array([0.25]), np.eye(2)[None]).real.tolist()
    [[[2.0, 0.25], [0.25, 2.0]]]
    """
    if shape is None:
        return Phi_vv
    N = np.asarray(n_vv)[..., None, None]
    L = 0.5 * np.real(Phi_vv[..., 0, 0] + Phi_vv[..., 1, 1])[..., None, None]
    return N * Phi_vv + (1.0 - N) * L * shape


@dataclass(frozen=True)
class _NoiseStatsParams(StftParams):
    """Filter bank, noise statistics and loading fields shared by ``mvdr`` and ``mwf``."""

    spp: str = "single"
    tau_noisy_s: float = 1.0
    tau_noise_s: float = 0.5
    prior_absence: float = 0.5
    loading: float = 1e-3
    startup_prior: str = "diffuse"
    noisy_weight: str = "spp"

    def _check_stats(self):
        self._check_stft()
        check_stats_fields(self)
        check_range("loading", self.loading, 0.0, 1e3)
        check_choice("startup_prior", self.startup_prior, STARTUP_PRIORS)
        _stats_config(self, 16000)  # the stage's own checks of its fields' combination


@functools.lru_cache(maxsize=64)
def _stats_config(params: _NoiseStatsParams, fs: int) -> NoiseStatsConfig:
    # cached: built once per (params, fs), not per streamed block
    return NoiseStatsConfig(hop_s=params.hop / fs, spp=params.spp, tau_noisy_s=params.tau_noisy_s,
                            tau_noise_s=params.tau_noise_s, prior_absence=params.prior_absence,
                            noisy_weight=params.noisy_weight)


@functools.lru_cache(maxsize=64)
def _prior_matrix(kind: str, n_bins: int, frame_len: int, fs: int, spacing_m: float, c_mps: float):
    # cached: the same matrix serves every streamed block of a run, not rebuilt per block
    if kind == "none":
        return None
    if kind == "white":
        return np.broadcast_to(np.eye(2, dtype=complex), (n_bins, 2, 2))
    g = diffuse_coherence(np.arange(n_bins) * fs / frame_len, spacing_m=spacing_m, c_mps=c_mps)
    m = np.stack([np.stack([np.ones_like(g), g], -1), np.stack([g, np.ones_like(g)], -1)], -2).astype(complex)
    m.flags.writeable = False
    return m


class Mvdr(StftEnhancer):
    """Adaptive MVDR with the GEVD RTF on SPP-weighted noise statistics (see module docstring).

    Two channels in (reference mic first), one out; ``trace["weights"]`` ``(n_frames, n_bins, 2)``
    and ``trace["spp"]`` ``(n_frames, n_bins)``.

    >>> import numpy as np, enhancers
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((2, 8000))
    >>> r = enhancers.make("mvdr").process(x, 16000)
    >>> r.output.shape, r.trace["weights"].shape
    ((1, 8000), (62, 129, 2))
    """

    name: ClassVar[str] = "mvdr"
    version: ClassVar[str] = "2"
    summary: ClassVar[str] = "adaptive MVDR: GEVD RTF on SPP-weighted noise covariances (reference mic 0)"

    @dataclass(frozen=True)
    class Params(_NoiseStatsParams):
        def __post_init__(self):
            self._check_stats()

    def _config(self, fs: int) -> NoiseStatsConfig:
        return _stats_config(self.params, fs)

    def _tradeoff(self) -> float:
        return 0.0

    def _algo_init(self, fs, n_bins):
        return noise_stats_init(n_bins)

    def _frames(self, X, algo, fs):
        stats, algo = noise_stats_step(X, algo, self._config(fs))
        vv = with_startup_prior(stats.vv, stats.n_vv, self._prior_shape(X.shape[2], fs))
        w = rank1_mwf_weights(stats.yy, vv, self._tradeoff(), loading=self.params.loading)
        Y = np.sum(np.conj(w) * np.moveaxis(X, 0, -1), axis=-1)
        return Y[None], algo, {"weights": w, "spp": stats.p}

    def _prior_shape(self, n_bins: int, fs: int) -> np.ndarray | None:
        """The start-up prior's ``(n_bins, 2, 2)`` coherence matrix, or None (no prior)."""
        p = self.params
        return _prior_matrix(p.startup_prior, n_bins, self.filterbank.frame_len, fs, p.spacing_m, p.c_mps)

    def _apply(self, record, X, fs):
        return np.sum(np.conj(record["weights"]) * np.moveaxis(X, 0, -1), axis=-1)[None]

    def _trace(self, record):
        return {"weights": record["weights"], "spp": record["spp"]}


class Mwf(Mvdr):
    """Speech-distortion-weighted multichannel Wiener filter, rank-1 form (``"mwf"``; module docstring).

    ``mu`` (>= 0, default 1: MVDR + single-channel Wiener post-filter; 0: the MVDR).

    >>> import numpy as np, enhancers
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((2, 8000))
    >>> enhancers.make("mwf", mu=0.0).process(x, 16000).output.shape
    (1, 8000)
    """

    name: ClassVar[str] = "mwf"
    version: ClassVar[str] = "2"
    summary: ClassVar[str] = "speech-distortion-weighted MWF (rank-1, GEVD) on SPP-weighted noise covariances"

    @dataclass(frozen=True)
    class Params(_NoiseStatsParams):
        mu: float = 1.0

        def __post_init__(self):
            self._check_stats()
            check_range("mu", self.mu, 0.0, 1e6)

    def _tradeoff(self) -> float:
        return float(self.params.mu)


class MvdrSs(Chain):
    """``mvdr`` then ``ss``: the adaptive MVDR's one channel feeds spectral subtraction (``"mvdr-ss"``)."""

    name = "mvdr-ss"
    version = "2"
    summary = "adaptive MVDR (GEVD RTF) followed by spectral subtraction"
    stages = (("mvdr", "mvdr"), ("ss", "ss"))


V1_DEFAULTS = {"startup_prior": "none", "noisy_weight": "every"}
"""What version 1 of ``mvdr`` / ``mwf`` / ``mvdr-ss`` did: no start-up prior, the noisy average every frame."""


class MvdrV1(Mvdr):
    """``mvdr@1``: ``mvdr`` with :data:`V1_DEFAULTS` (kept so that earlier numbers can be rerun).

    >>> import enhancers
    >>> enhancers.make("mvdr@1").params.noisy_weight, enhancers.make("mvdr").params.noisy_weight
    ('every', 'spp')
    """

    version: ClassVar[str] = "1"
    Params = params_with_defaults(Mvdr.Params, "MvdrV1", V1_DEFAULTS, __name__)


class MwfV1(Mwf):
    """``mwf@1``: ``mwf`` with :data:`V1_DEFAULTS`."""

    version: ClassVar[str] = "1"
    Params = params_with_defaults(Mwf.Params, "MwfV1", V1_DEFAULTS, __name__)


class MvdrSsV1(Chain):
    """``mvdr-ss@1``: ``mvdr@1`` then ``ss``."""

    name = "mvdr-ss"
    version = "1"
    summary = "adaptive MVDR (GEVD RTF), version 1, followed by spectral subtraction"
    stages = (("mvdr", "mvdr@1"), ("ss", "ss"))
