"""Differential beamformer on the noise statistics (``"eb-spp"``, ``"eb-spp-ss"``).

The robust EB's three adaptive quantities -- the rear mic's response, beta and the delay-and-sum
weight -- each answer one question about the noise: its cross-spectrum between the mics. Here all
three are read from one noise covariance per bin, ``Phi_vv[l, k]`` (2 x 2), which
:mod:`enhancers.beam.noise_stats` averages with the weight ``1 - p`` of the speech presence
probability ``p`` (Gerkmann & Hendriks 2012's SPP on the pair's mean periodogram by default, whose weights
scale both mics' noise alike; on the front mic alone with ``spp="single"``; Souden et al. 2010's
multichannel SPP with ``spp="multi"``). A cell the talker dominates (``p -> 1``) leaves the
average where it was, so no separate freeze rule decides when to learn; this is Elko's NLMS with a step
weighted by ``1 - p``, solved in closed form at every frame.

Per frame ``l`` and bin ``k`` (``e = exp(-j w_k T)``, ``T`` the inter-mic delay in samples), from
``Phi = Phi_vv[l - 1, k]`` (the frames *before* ``l``: a frame never steers its own weights):

0. **Start-up prior.** The normalised average ``Phi = R / N`` (``N`` the weight of the frames it holds,
   0 at the start, -> 1 once filled) would let the first frames weigh fully. Instead the unfilled mass
   ``1 - N`` goes to the diffuse-field model at the average's own level (a conjugate prior with a
   pseudo-count that decays as data arrive)::

       Phi <- N Phi + (1 - N) L Gamma,   L = tr(Phi) / 2,   Gamma = [[1, gamma], [gamma, 1]],
       gamma = sinc(2 f d / c)                                   (spherically isotropic field)

   whose beta and DAS weight are those of a diffuse field, i.e. where the beamformer would settle in
   the commonest noise, until noise frames say otherwise.
1. **Calibration.** A slower one-pole average of ``(S11, S22, S21) = (Phi_00, Phi_11, Phi_10)`` with
   time constant ``tau_cal_s`` (the mismatch is a slowly varying sensor property), started at zero with
   its unfilled mass ``lam^l`` filled the same way (``lam = exp(-hop / tau_cal_s)``); ``r_hat`` from it
   by :func:`enhancers.beam.mic_calibration.estimate_from_averages`: ``|r| = sqrt(S22 / S11)`` (equal
   power at both mics in a far-field or diffuse noise field), ``angle(r)`` the phase of ``S21`` with
   the propagation slope removed (the diffuse-field coherence is real), both averaged over
   ``~smooth_frac k`` neighbouring bins and clipped to ``+-max_gain_db`` / ``+-max_phase_deg``; where
   the band coherence is below 0.3 the phase is held. ``tau_cal_s = 0``: ``r_hat`` from ``Phi`` itself.
   The rear spectrum is divided by ``r_hat``; ``Phi`` is transformed the same way,
   ``Phi_c = D^-1 Phi D^-H``, ``D = diag(1, r_hat)``.
2. **Beta.** The forward and backward cardioids are ``cF = a^T x``, ``cB = b^T x`` with
   ``a = (1, -e)``, ``b = (-e, 1)``; the noise output power ``E|cF - beta cB|^2`` is least for
   ``beta = Re(a^T Phi_c b*) / (b^T Phi_c b*)`` -- the fixed point of Elko's NLMS (algorithms.md
   section 5) on the noise alone -- clipped to ``[0, 1]`` (the null in the rear half plane).
3. **Equaliser.** :func:`enhancers.core.eq.look_eq_gain` of a fixed cardioid (``beta = 0``) with the
   white-noise-gain bound ``eq_noise_gain_db = 9`` dB, an 80 Hz high-pass and the 90-degree phase
   correction: the look-direction talker's path never follows beta.
4. **DAS weight.** ``Y = Y_d - alpha (Y_d - Y_s)`` between the differential output ``Y_d`` and a
   delay-and-sum ``Y_s`` with the same look response; ``alpha`` minimises the noise output power
   under ``Phi_c`` (its closed form as for beta), clipped to ``[0, 1]``: ~1 where the noise is
   incoherent between the mics (wind, self-noise), which no differential pattern reduces.

The output is ``Y = w^T X`` with ``w (2,)`` per frame and bin: a linear operation once ``w`` is
recorded, so ``Result.replay`` is exact. Before any noise is seen ``beta = 0`` (cardioid),
``alpha = 1/2`` and ``r_hat = 1``.

Cost. The frame loop of the statistics (:mod:`enhancers.kernels.noise_stats`, for the single-channel
tracker ``"mean"`` / ``"single"``) and steps 0-4 (:mod:`enhancers.kernels.spp_eb`) run compiled; the numpy
code here stays the reference (``compiled = False``; equal to rounding, ``tests/test_spp_eb_kernel.py``).
Batch CPU time 1.63-1.76x ``eb-robust@1``'s (RTF 0.0040-0.0042 against 0.0024-0.0025), streaming RTF
0.011 (``python -m benchmarks.perf.enhancer_rtf --only eb-spp eb-robust@1 --ratio eb-spp eb-robust@1``,
three runs, AMD EPYC 2 cores at load 0.6).  First call in a new process 0.19 s with numba's on-disk
cache, 6.1 s when the kernels compile.

Parameters (``SppElkoBeamformer.Params``; the geometry and filter-bank fields of
:class:`enhancers.core.stft_stage.StftParams` besides), eight: ``spp`` ("mean"; Gerkmann & Hendriks
2012 on the pair's mean periodogram, :mod:`enhancers.beam.noise_stats`), ``tau_noise_s`` (0.5 s, the
noise average; Souden et al. 2011 use 0.92 per 8 ms frame ~ 0.1 s, longer here because beta only needs
the noise's spatial shape), ``tau_cal_s`` (4 s), ``prior_absence``
(0.5, the multichannel SPP's ``q``; Gerkmann & Hendriks' fixed prior), ``fit_band_hz`` ((500, 4000)
Hz), ``smooth_frac`` (0.06), ``max_gain_db`` (6), ``max_phase_deg`` (30), the last four those of
:mod:`enhancers.beam.mic_calibration`'s default.

Accuracy. In 24 s of simulated diffuse noise with a rear mic 2 dB / 15 deg off, the estimate over
300 Hz-3 kHz is within 0.18 dB / 2.1 deg in every bin (median 0.05-0.09 dB) with the default SPP; the
multichannel SPP's within 0.14 dB; the front-mic SPP (``spp="single"``) biases the gain by 0.1-0.16 dB
(median bin; worst 0.42 dB), its weights following the front mic's power alone
(``tests/test_spp_eb.py``). Held out -- ``phone`` at 15-25 dB input, test split, seeds 0-9, 120 rows
(``python -m benchmarks.studies.heldout_targets --split test --seeds 10 [--data-dir DIR]``):

* built-in data: speech jitter <= -30 dB in 57 % of the rows, median -31.0 dB, worst -16.0 dB
  (``eb-robust@1``: 2 %, -16.6, -3.9); replay and Hagerman SNR-I within 3 dB in 98 % (52 %); SNR-I minus
  ``eb-robust@1``'s per noise (mean, lower 95 % bound) +0.38 (+0.11) babble, +0.28 (-0.27) factory,
  +1.58 (+1.19) factory-hall, +0.48 (-0.01) wind; raw PESQ +0.10 ... +0.11 except wind (-0.01);
* ``/work/shared/data``'s test half (other talkers, the recordings' test segments): jitter <= -30 dB in
  48 %, worst -15.0 dB, agreement 99 %; SNR-I minus ``eb-robust@1``'s -0.11 (-0.38) babble, -0.82
  (-1.34) factory, +1.42 (+1.06) factory-hall, +0.29 (-0.16) wind.

Why the talker's path still moves: steps 2-4 keep the look response constant for a talker on the
axis only.  ``phone``'s talker is 45 deg off it, so it reaches the backward cardioid and the two paths
of step 4 with different responses, and every change of alpha, ``r_hat`` or beta between Hagerman's
two runs moves it (``python -m benchmarks.studies.jitter_sources``: alpha alone -21.8 ... -43.5 dB,
``r_hat`` alone -32.4 ... -38.5, beta alone -26.9 ... -56.9, below 1 kHz, where the equaliser's gain
is large).  With a rear mic 1 dB / 5 deg off the SNR-I loss is 0.04-0.60 dB (135 / 240 deg, diffuse
babble; ``benchmarks.studies.robust_eb``'s scenes), but a single rear plane wave is reduced ~12 dB less
than by ``eb-robust@1`` (16.4 vs 28.6 dB SNR-I at 135 deg).

References
----------
G. W. Elko and A.-T. Nguyen Pong, "A simple adaptive first-order differential microphone", IEEE
WASPAA 1995. T. Gerkmann, R. C. Hendriks, "Unbiased MMSE-based noise power estimation with low
complexity and low tracking delay", IEEE TASLP 20(4), 2012. M. Souden, J. Chen, J. Benesty, S. Affes,
"Gaussian model-based multichannel speech presence probability", IEEE TASLP 18(5), 2010, and "An
integrated solution for online multichannel noise tracking and reduction", IEEE TASLP 19(7), 2011.
N. Dal Degan, C. Prati, "Acoustic noise analysis and speech enhancement techniques for mobile radio
applications", Signal Processing 15, 1988 (the diffuse-field coherence sinc(2 f d / c)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.beam.mic_calibration import _check_band, estimate_from_averages
from enhancers.beam.noise_stats import (
    NoiseStatsConfig,
    check_stats_fields,
    noise_stats_init,
    noise_stats_step,
)
from enhancers.core.chain import Chain
from enhancers.core.eq import look_eq_gain
from enhancers.core.stft_stage import TINY, StftEnhancer, StftParams, bin_omega, smooth_frames
from scenesim.errors import ParameterError
from scenesim.validate import check_range

__all__ = ["EbSppSs", "SppElkoBeamformer", "closed_form_weights"]

_BETA0, _ALPHA0 = 0.0, 0.5  # the priors before any noise is seen (module docstring)
MIN_COHERENCE = 0.3  # below this band coherence the calibration's phase is held (mic_calibration's default)
_REG = 1e-12  # relative regulariser of the two least-squares ratios (re the noise power in the bin)


def _quad(u: np.ndarray, Phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``u^T Phi conj(v)`` per cell: ``E[(u^T x)(v^T x)*]`` for ``E[x x^H] = Phi``; shapes ``(..., 2)``,
    ``(..., 2, 2)``, ``(..., 2)`` -> ``(...)``."""
    return np.einsum("...i,...ij,...j->...", u, Phi, np.conj(v))


def _ls_weight(num: np.ndarray, den: np.ndarray, scale: np.ndarray, prior: float) -> np.ndarray:
    """``clip((num + prior r) / (den + r), 0, 1)``, ``r = _REG scale + TINY``: the least-squares weight,
    the prior where the bin holds no noise power yet."""
    r = _REG * scale + TINY
    return np.clip((num + prior * r) / (den + r), 0.0, 1.0)


def closed_form_weights(Phi: np.ndarray, e: np.ndarray, G: np.ndarray, look: np.ndarray, *,
                        das_mix: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Beta, DAS weight and output weights ``w`` of the calibrated pair under the noise covariance ``Phi``.

    Parameters
    ----------
    Phi : ndarray, complex, shape ``(..., K, 2, 2)``
        Noise covariance of the calibrated spectra ``x = (X1, X2 / r_hat)``.
    e : ndarray, complex, shape ``(K,)``
        ``exp(-j w T)`` per bin.
    G : ndarray, complex, shape ``(K,)``
        Look-direction equaliser of the differential output.
    look : ndarray, shape ``(K,)``
        The differential path's look response ``|G 2 sin(w T)|`` (the DAS path gets the same).
    das_mix : bool
        Mix with the delay-and-sum (else ``alpha = 0``).

    Returns
    -------
    beta, alpha : ndarray, shape ``(..., K)``
    w : ndarray, complex, shape ``(..., K, 2)``
        ``Y = w[..., 0] X1 + w[..., 1] X2c``.

    Examples
    --------
    A point noise source from the rear endfire (180 deg) reaches the rear mic one delay earlier; its
    covariance is ``d d^H`` with ``d = (e, 1)``, which the backward cardioid ``cB`` cancels, so
    ``beta = 0`` (a cardioid) nulls it:

    >>> import numpy as np
    >>> e = np.exp(-1j * np.array([0.3, 0.6]))
    >>> d = np.stack([e, np.ones(2)], axis=-1)
    >>> Phi = d[..., :, None] * np.conj(d[..., None, :])
    >>> beta, alpha, w = closed_form_weights(Phi, e, np.ones(2), np.ones(2), das_mix=False)
    >>> np.round(beta, 6).tolist(), np.allclose(np.einsum("ki,ki->k", w, d), 0)
    ([0.0, 0.0], True)
    """
    a = np.stack([np.ones_like(e), -e], axis=-1)  # cF = a^T x
    b = np.stack([-e, np.ones_like(e)], axis=-1)  # cB = b^T x
    scale = np.abs(Phi[..., 0, 0]) + np.abs(Phi[..., 1, 1])
    beta = _ls_weight(_quad(a, Phi, b).real, _quad(b, Phi, b).real, scale, _BETA0)
    d = G[:, None] * (a - beta[..., None] * b)  # Y_d = d^T x
    if not das_mix:
        return beta, np.zeros_like(beta), d
    s = (0.5 * look)[:, None] * np.stack([e, np.ones_like(e)], axis=-1)  # Y_s = s^T x (unit look gain x look)
    diff = d - s
    alpha = _ls_weight(_quad(d, Phi, diff).real, _quad(diff, Phi, diff).real, scale, _ALPHA0)
    return beta, alpha, d - alpha[..., None] * diff


class SppElkoBeamformer(StftEnhancer):
    """Calibrated sub-band Elko beamformer whose calibration, beta and DAS weight are read from an
    SPP-weighted noise covariance (see module docstring).

    Examples
    --------
    >>> import numpy as np, enhancers
    >>> e = enhancers.make("eb-spp")
    >>> res = e.process(np.random.default_rng(0).standard_normal((2, 8000)), 16000)
    >>> res.output.shape, res.trace["beta"].shape
    ((1, 8000), (62, 129))
    """

    name: ClassVar[str] = "eb-spp"
    version: ClassVar[str] = "3"
    summary: ClassVar[str] = "EB with calibration, beta and DAS weight from an SPP-weighted noise covariance"

    @dataclass(frozen=True)
    class Params(StftParams):
        spp: str = "mean"
        tau_noise_s: float = 0.5
        tau_cal_s: float = 4.0
        prior_absence: float = 0.5
        fit_band_hz: tuple[float, float] = (500.0, 4000.0)
        smooth_frac: float = 0.06
        max_gain_db: float = 6.0
        max_phase_deg: float = 30.0

        def __post_init__(self):
            self._check_stft()
            check_stats_fields(self)
            _check_band("fit_band_hz", self.fit_band_hz)
            check_range("smooth_frac", self.smooth_frac, 0.0, 1.0)
            check_range("max_gain_db", self.max_gain_db, 0.0, 40.0)
            check_range("max_phase_deg", self.max_phase_deg, 0.0, 180.0)
            check_range("tau_cal_s", self.tau_cal_s, 0.0, 600.0)

        def stats_config(self, fs: int) -> NoiseStatsConfig:
            """The noise-statistics stage's constants at rate ``fs``."""
            return NoiseStatsConfig(hop_s=int(self.hop) / fs, spp=self.spp, tau_noise_s=float(self.tau_noise_s),
                                    prior_absence=float(self.prior_absence))

    # fixed parts of the method (module docstring): not parameters
    EQ = {"max_gain_db": 25.0, "noise_gain_db": 9.0, "highpass_hz": 80.0}
    #: run steps 0-4's per-frame closed forms compiled (:mod:`enhancers.kernels.spp_eb`); False: numpy reference
    compiled: ClassVar[bool] = True

    def _constants(self, fs: int):
        """``(e, G, look, band, max_slope)`` at rate ``fs`` (cached: params are frozen)."""
        cache = self.__dict__.setdefault("_constants_at", {})
        if fs not in cache:
            cache[fs] = self._compute_constants(fs)
        return cache[fs]

    def _compute_constants(self, fs: int):
        p = self.params
        n = int(p.frame_len)
        omega = bin_omega(n)
        T = self.delay_samples(fs)
        e = np.exp(-1j * omega * T)
        g = look_eq_gain(np.zeros(omega.shape), omega=omega, delay_samples=T, freqs_hz=omega / (2 * np.pi) * fs,
                         **self.EQ)
        G = -1j * g  # the look response 2j sin(wT) e^{-jwT} X1: -j undoes the j
        look = np.abs(G) * np.abs(2.0 * np.sin(omega * T))
        f_hz = omega / (2 * np.pi) * fs
        lo, hi = (float(v) for v in p.fit_band_hz)
        k = np.flatnonzero((f_hz >= lo) & (f_hz <= min(hi, fs / 2)))
        if k.size < 3:
            raise ParameterError("fit_band_hz", p.fit_band_hz, f"a band holding >= 3 bins at fs={fs}")
        max_slope = 2.0 * math.pi * T / n  # the propagation phase slope of an endfire source, rad per bin
        return e, G, look, slice(int(k[0]), int(k[-1]) + 1), max_slope

    def _algo_init(self, fs, n_bins):
        # the stage's state, the held phase, the calibration average's last value and its unfilled mass
        return (noise_stats_init(n_bins), np.zeros(n_bins), np.zeros((3, n_bins), dtype=complex), 1.0)

    def _frames(self, X, algo, fs):
        p = self.params
        stats_state, held, cal_prev, missing = algo
        _, _, _, band, max_slope = self._constants(fs)
        prev = stats_state.r_vv / np.maximum(stats_state.n_vv, TINY)[:, None, None]
        stats_state_n = stats_state.n_vv
        stats, stats_state = noise_stats_step(X, stats_state, p.stats_config(fs), kernel=True, noisy=False)
        before = (prev, stats.vv, stats_state_n, stats.n_vv)  # row l's weights come from the frames before l
        if self.compiled and X.shape[1] and p.tau_cal_s > 0:
            cal, cal_prev, missing = self._compiled_calibration(before, cal_prev, missing, fs)
            r_hat = self._rear_response(cal, held, band, max_slope)
            Y, w_raw, beta, alpha = self._compiled_weights(before, 1.0 / r_hat, X, fs)
        else:
            Phi = np.concatenate([prev[None], stats.vv[:-1]]) if X.shape[1] else stats.vv
            N = np.concatenate([stats_state_n[None], stats.n_vv[:-1]]) if X.shape[1] else stats.n_vv
            Phi = self._with_prior(Phi, N, fs)
            avg = np.stack([Phi[..., 0, 0], Phi[..., 1, 1], Phi[..., 1, 0]], axis=1)  # (F, 3, K)
            cal, cal_prev, missing = self._calibration_average(avg, cal_prev, missing, fs)
            r_hat = self._rear_response(cal, held, band, max_slope)
            Y, w_raw, beta, alpha = self._weights(Phi, 1.0 / r_hat, X, fs)
        held = np.angle(r_hat[-1]) if X.shape[1] else held
        record = {"w": w_raw, "beta": beta, "alpha": alpha, "r_hat": r_hat, "spp": stats.p}
        return Y[None], (stats_state, held, cal_prev, missing), record

    def _compiled_calibration(self, before, cal_prev, missing, fs):
        """Steps 0-1's averages by :func:`enhancers.kernels.spp_eb.prior_and_calibration`: ``(cal (F, 3, K),
        last average, unfilled mass)`` (``_with_prior`` and ``_calibration_average`` are the reference)."""
        from enhancers.kernels.spp_eb import prior_and_calibration  # lazy: numba

        lam = math.exp(-int(self.params.hop) / fs / float(self.params.tau_cal_s))
        return prior_and_calibration(*self._contiguous(before), self._coherence(fs), lam,
                                     np.asarray(cal_prev, dtype=complex), float(missing))

    def _compiled_weights(self, before, inv, X, fs):
        """Steps 2-4 by :func:`enhancers.kernels.spp_eb.closed_form_frames` (``_weights`` is the reference)."""
        from enhancers.kernels.spp_eb import closed_form_frames  # lazy: numba

        e, G, look, _, _ = self._constants(fs)
        return closed_form_frames(*self._contiguous(before), self._coherence(fs), np.ascontiguousarray(inv), e,
                                  G.astype(complex), look, np.ascontiguousarray(X), _BETA0, _ALPHA0)

    @staticmethod
    def _contiguous(arrays):
        return tuple(np.ascontiguousarray(a) for a in arrays)

    def _rear_response(self, cal, held, band, max_slope):
        """``r_hat (F, K)`` from the calibration averages ``cal (F, 3, K)`` (step 1):
        :func:`enhancers.beam.mic_calibration.estimate_from_averages`, or its compiled copy
        (:func:`enhancers.kernels.spp_eb.estimate_frames`)."""
        p = self.params
        if self.compiled and cal.shape[0]:
            from enhancers.kernels.spp_eb import estimate_frames  # lazy: numba

            half = np.maximum(1, np.round(float(p.smooth_frac) * np.arange(cal.shape[2])).astype(np.int64))
            return estimate_frames(np.ascontiguousarray(cal), band.start, band.stop, max_slope, half,
                                   float(p.max_gain_db), math.radians(float(p.max_phase_deg)), MIN_COHERENCE,
                                   np.asarray(held, dtype=float), 1.0)
        return estimate_from_averages(cal, band=band, max_slope=max_slope, smooth_bins=1,
                                      smooth_frac=float(p.smooth_frac), max_gain_db=float(p.max_gain_db),
                                      max_phase_deg=float(p.max_phase_deg), min_coherence=MIN_COHERENCE,
                                      prev_phase=held)

    def _weights(self, Phi, inv, X, fs):
        """``(Y (F, K), w (F, K, 2) on the uncalibrated spectra, beta, alpha)`` for the noise covariance
        ``Phi (F, K, 2, 2)`` and the rear mic's inverse response ``inv (F, K)``: steps 2-4 (numpy)."""
        e, G, look, _, _ = self._constants(fs)
        Phi_c = Phi.copy()
        Phi_c[..., 0, 1] *= np.conj(inv)
        Phi_c[..., 1, 0] *= inv
        Phi_c[..., 1, 1] *= np.abs(inv) ** 2
        beta, alpha, w = closed_form_weights(Phi_c, e, G, look)
        w_raw = np.stack([w[..., 0], w[..., 1] * inv], axis=-1)  # on the uncalibrated spectra
        return w_raw[..., 0] * X[0] + w_raw[..., 1] * X[1], w_raw, beta, alpha

    def _calibration_average(self, avg, prev, missing, fs):
        """The calibration's average of ``avg (F, 3, K)`` (one-pole, ``tau_cal_s``, zero start) with its
        unfilled mass ``lam^l`` filled by the diffuse-field prior at the current level (``startup``)."""
        p = self.params
        if p.tau_cal_s <= 0 or avg.shape[0] == 0:
            return avg, prev, missing
        lam = math.exp(-int(p.hop) / fs / float(p.tau_cal_s))
        C = smooth_frames(avg, lam, prev)
        m = missing * lam ** np.arange(1, avg.shape[0] + 1)
        level = 0.5 * (avg[:, 0].real + avg[:, 1].real)  # (F, K): the current noise level per bin
        coh = self._coherence(fs)
        prior = level[:, None, :] * np.stack([np.ones_like(coh), np.ones_like(coh), coh])[None]
        return C + m[:, None, None] * prior, C[-1], float(m[-1])

    def _with_prior(self, Phi, N, fs):
        """``N Phi + (1 - N) L Gamma``: the noise average's unfilled mass ``1 - N`` (``N`` its normaliser)
        given to the diffuse-field model ``Gamma = [[1, gamma], [gamma, 1]]`` at the average's own level
        ``L = tr(Phi) / 2`` (module docstring, start-up prior); ``Phi (F, K, 2, 2)``, ``N (F, K)``."""
        coh = self._coherence(fs)
        fill = (1.0 - N) * 0.5 * (Phi[..., 0, 0].real + Phi[..., 1, 1].real)
        out = N[..., None, None] * Phi
        out[..., 0, 0] += fill
        out[..., 1, 1] += fill
        out[..., 0, 1] += fill * coh
        out[..., 1, 0] += fill * coh
        return out

    def _coherence(self, fs):
        """The diffuse-field coherence ``sinc(2 f d / c)`` per bin (a real number: ``omega T / pi``)."""
        omega = bin_omega(int(self.params.frame_len))
        return np.sinc(omega * self.delay_samples(fs) / np.pi)

    def _apply(self, record, X, fs):
        w = record["w"]
        return (w[..., 0] * X[0] + w[..., 1] * X[1])[None]

    def _trace(self, record):
        r = record["r_hat"]
        return {"beta": record["beta"], "alpha": record["alpha"], "spp": record["spp"],
                "rear_gain_db": 20.0 * np.log10(np.abs(r) + TINY), "rear_phase_deg": np.degrees(np.angle(r))}


class EbSppSs(Chain):
    """``eb-spp`` followed by ``ss`` (the thesis' cascade with this front end)."""

    name = "eb-spp-ss"
    version = "3"
    summary = "eb-spp followed by spectral subtraction (Martin 1994)"
    stages = (("eb", "eb-spp"), ("ss", "ss"))
