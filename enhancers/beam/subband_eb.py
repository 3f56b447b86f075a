"""Sub-band Elko beamformer: one NLMS beta per STFT bin (registry name ``"eb-subband"``).

Why per bin.  The exact response of ``y = cF - beta cB`` to a plane wave from ``theta``
(algorithms.md section 5, ``c = cos theta``) is proportional to
``sin(wT(1 + c)/2) - beta sin(wT(1 - c)/2)``, so a broadband interferer is nulled at every
frequency only if beta depends on frequency:

    beta_k(theta) = sin(w_k T (1 + c) / 2) / sin(w_k T (1 - c) / 2)        (1)

which lies in ``[0, 1]`` for every rear direction (``c <= 0``) and bin below Nyquist.  On
the WOLA filter bank (:mod:`enhancers.core.stft_stage`) bin ``k`` of frame ``l`` forms

    cF = X1 - e^{-j w_k T} X2,    cB = X2 - e^{-j w_k T} X1,    Y = cF - beta_k[l] cB

and beta is adapted per bin by normalised LMS on ``E|Y|^2`` (y with the old beta), once per frame::

    beta_k[l+1] = clip(beta_k[l] + mu Re(Y conj(cB)) / (P_B + eps P_1), 0, 1)
    P_B = lam P_B + (1 - lam) |cB|^2,   P_1 likewise for |X1|^2 (smoothed over frames, incl. frame l)

The clip keeps every bin's null in the rear half plane, so the frontal talker is never
the target of a null.  Adaptation gate (``adapt_gate_db``, as ``eb-gated``, here per bin):
frozen where ``10 log10(P_F / P_B) > min(floor, 0) + adapt_gate_db`` with one-pole smoothed
cardioid powers (``gate_lam``) and ``floor`` their running minimum over ``gate_floor_s``.

Real beta, not a complex weight (the decision the issue asks for).  With ideal (or
calibrated) microphones ``cF / cB`` of any plane wave is *real* (eq. 1), so a real beta
nulls it exactly: no degree of freedom is missing.  A rear-mic error ``r = g e^{j phi}``
makes the ratio complex, and then no real beta nulls the wave; a complex per-bin weight
``w`` would.  We keep the real beta and remove the mismatch in front of it with
:mod:`enhancers.beam.mic_calibration` (``eb-robust``) because (a) ``[0, 1]`` is a simple,
verifiable constraint that keeps the look direction: for the look direction ``cB = 0``
exactly only with matched mics, and with a mismatch the complex weight's leakage
``w (1 - r) e^{-jwT} X1`` into the talker is of the same size as the mismatch it
compensates, i.e. a complex weight that nulls a mismatched interferer also changes the
talker's response by an unknown amount; (b) a complex weight has no half-plane
constraint of comparable simplicity (it can place a null on the frontal talker whenever
the talker leaks into the update); (c) a complex weight that absorbs the mismatch does
so for one direction only (the mismatch is not a direction), so it must re-adapt for
every source, while a calibrated pair serves every direction and the diffuse field.
What the real beta cannot do (tested): null a mismatched plane wave; the residual is then
the mismatch term, which is why ``eb-subband`` alone degrades with mismatched mics.

DAS fallback (``das_mix``, off by default here, on in ``eb-robust``).  For noise that is
incoherent between the mics (wind, sensor self-noise) a differential pattern is worse
than the mics themselves at low frequencies: its noise PSD re the look direction is
``N / (4 sin^2(wT))`` (:mod:`enhancers.core.eq`), for the cardioid > 1 below ~2 kHz and +19 dB
at 200 Hz.  A delay-and-sum towards the look direction,
scaled to the same look response ``L = |G 2 sin(wT)|``, ``Yo = L (X1 e^{-jwT} + X2) / 2``,
halves it instead.  Per bin the output is ``Y = Yd - alpha D`` with ``D = Yd - Yo`` (no
look-direction component, for matched mics) and ``alpha = clip(<Re(Yd D*)> / <|D|^2>, 0, 1)``,
the least-squares weight from one-pole averages (``mix_lam``) over earlier unfrozen frames
(products averaged over ``2 mix_smooth_bins + 1`` neighbouring bins, regularised towards the
prior ``mix_alpha0`` relative to the noise-only front-mic power; see :func:`das_mix_step`):
``alpha -> 1`` in incoherent noise (closed form: ``<Yd Yo*> = <|Yo|^2>`` there), ``-> 0`` where
the differential null wins (a rear plane wave).  ``trace["alpha"]``: ``(n_frames, n_bins)``.

Equaliser: :func:`enhancers.core.eq.look_eq_gain` per bin (exact look-direction inverse,
``eq_max_gain_db`` cap; ``eq_noise_gain_db`` the noise-aware white-noise-gain bound;
``eq_highpass_hz``).  ``eq_phase`` (off here, on in ``eb-robust``) also multiplies by ``-j``:
the look-direction response ``2j sin(wT) e^{-jwT}`` then becomes the front mic delayed by
``T`` rather than its 90-degree-shifted version (a time-domain integrator undoes the shift
too), so the output lines up with the reference at the declared latency plus ``T fs``
samples.  The price: multiplying a frame by ``-j`` is a Hilbert transform within the
frame, which spreads the frame's small model error (a plane wave's delay is exact only
approximately frame by frame) from the window edges over the whole frame, so the
broadband null of white noise at 120/135/150 deg drops from 33.3/32.1/31.6 dB to
31.1/29.8/29.0 dB.  Without it the output is the look-direction speech shifted by 90
degrees (inaudible, but a waveform comparison finds its best lag ~10 samples off).
``eq_bound_beta`` (off by default, 0 in ``eb-robust-blind``): the noise-aware bound of the EQ is that of the
fixed pattern ``cF - b cB`` instead of the adapted one.  The talker passes through the EQ, so an EQ that
follows beta moves the talker's path with every speech x noise cross term beta learns from: on ``phone``
(shared data, 2 seeds, 15-25 dB, ``python -m benchmarks.studies.calibration_jitter --decompose``) the jitter
carried by beta and its EQ falls from a median of -19.3 dB (worst -14.8) to -28.8 dB (worst -17.5) with
``b = 0``, and ``eb-robust-ss``'s SNR-I per noise rises by 0.2-0.4 dB; ``b = 1`` (the strictest bound) costs
2-3 dB in factory and the hall.

Pooled and delayed estimates (``eb-robust-blind``): ``mix_bands_hz`` fits the DAS weight per band from the
cells its masks leave open (:func:`enhancers.beam.beam_pool.pooled_mix_step`), and ``mix_model="delayed"`` /
``beta_model="delayed"`` learn the DAS weight and a least-squares beta per bin ``level_ahead_s`` late on the
calibration's held weights (the talker's onset known before a frame is learned), with start-up stand-ins
learned at once (``mix_fast_cells``, ``beta_fast_frames``).

``trace["beta"]``: ``(n_frames, n_bins)``, the beta applied to each frame.  Latency
``frame_len - 1`` samples.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.ndimage import uniform_filter1d

from enhancers.beam.beam_pool import band_onehot, beta_from_cos, pooled_mix_step
from enhancers.core.eq import look_eq_gain
from enhancers.core.stft_stage import (
    TINY,
    GateState,
    StftEnhancer,
    StftParams,
    bin_omega,
    gate_init,
    ratio_gate,
    smooth_frames,
)
from enhancers.kernels import frames as fast_frames
from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_int, check_range

__all__ = ["SubbandElkoBeamformer", "SubbandState", "closed_form_beta", "subband_beta_step"]


def closed_form_beta(theta_deg: float, omega_t) -> np.ndarray:
    """Per-bin beta nulling a plane wave from ``theta_deg`` exactly (eq. 1), ``omega_t = w T`` (rad).

    >>> round(float(closed_form_beta(120.0, 0.01)), 3)   # low frequency: (1 + c) / (1 - c) = 1/3
    0.333
    """
    return beta_from_cos(math.cos(math.radians(theta_deg)), omega_t)


@dataclass(frozen=True)
class SubbandState:
    """Per-bin adaptation state ``(K,)`` arrays, plus the gate's running-minimum history."""

    beta: np.ndarray
    p_b: np.ndarray
    p_1: np.ndarray
    gate: GateState
    alpha: np.ndarray | None = None  # (K,) das_mix: averages of Re(Yd conj(D)) and |D|^2
    p_d: np.ndarray | None = None
    p_m: np.ndarray | None = None  # (K,) das_mix: average of P_1 over the same (unfrozen) frames
    mix_n: np.ndarray | None = None  # (B,) mix_bands_hz: learned cells per band (then alpha/p_d/p_m are (B,))
    mix_pend: tuple | None = None  # mix_model="delayed": the last frames' (Y, D, p1), (D, K) each, not yet judged
    mix_fast: tuple | None = None  # mix_fast_cells: the start-up weight's averages (as alpha, p_d, p_m, mix_n)
    beta_pend: tuple | None = None  # beta_model="delayed": the last frames' (cF, cB, p1, open), (D, K) each
    beta_ls: tuple | None = None  # beta_model="delayed": per-bin averages (S_FB, S_BB, S_11, n), (K,) each
    beta_fast: tuple | None = None  # beta_fast_frames: the start-up beta's averages (as beta_ls)
    frames: int = 0  # frames seen since the stream start, before this block (the delayed models' start)


def subband_init(n_bins: int, beta0: float) -> SubbandState:
    z = np.zeros(n_bins)
    return SubbandState(beta=np.full(n_bins, float(beta0)), p_b=z, p_1=z, gate=gate_init(n_bins), alpha=z, p_d=z,
                        p_m=z)


def _gate_frozen(cF, cB, state: SubbandState, *, gate_db: float, lam: float, n_window: int):
    """Per-bin gate: True where frozen; returns ``(frozen (F, K), state changes)``."""
    frozen, gate = ratio_gate(cF, cB, state=state.gate, gate_db=gate_db, lam=lam, n_window=n_window)
    return frozen, {"gate": gate}


def _learn_frozen(cF, cB, state: SubbandState, *, gate_db, gate_lam, gate_window, also_frozen):
    """``(frozen (F, K) or None, state changes)``: the gate's mask (``gate_db`` None: off) OR ``also_frozen``."""
    changes = {}
    frozen = None
    if gate_db is not None:
        frozen, changes = _gate_frozen(cF, cB, state, gate_db=gate_db, lam=gate_lam, n_window=gate_window)
    if also_frozen is not None:
        frozen = also_frozen if frozen is None else (frozen | also_frozen)
    return frozen, changes


def subband_beta_step(cF, cB, X1, state: SubbandState, *, mu: float, lam: float, eps: float,
                      gate_db: float | None = None, gate_lam: float | None = None, gate_window: int = 0,
                      extras: dict | None = None, also_frozen: np.ndarray | None = None):
    """Per-bin NLMS over the frames of one block (vectorised over bins; a loop over frames).

    Parameters
    ----------
    cF, cB, X1 : complex arrays (F, K)
        Forward/backward cardioids and the front mic's spectrum.
    state : SubbandState
    mu, lam, eps : NLMS step, power smoothing per frame, regularisation re ``P_1``.
    gate_db, gate_lam, gate_window : adaptation gate (None: off); window in frames (0: no floor).
    extras : dict, optional
        Filled with ``"frozen"`` (the gate's mask or None) and ``"p1"`` (smoothed ``|X1|^2``, (F, K)).
    also_frozen : bool (F, K), optional
        Cells where beta must not learn either (OR-ed with the gate's mask).

    Returns
    -------
    betas : (F, K), the beta applied to each frame; new state.
    """
    F = cF.shape[0]
    if F == 0:  # a block shorter than a hop: nothing to adapt
        if extras is not None:
            extras.update(frozen=None, p1=np.zeros(cF.shape))
        return np.zeros(cF.shape), state
    bb = cB.real**2 + cB.imag**2
    pb = smooth_frames(bb, lam, state.p_b)
    p1 = smooth_frames(X1.real**2 + X1.imag**2, lam, state.p_1)
    den = pb + eps * p1 + TINY
    # beta + mu Re((cF - beta cB) cB*) / den = beta keep + gain
    gain = mu * (cF.real * cB.real + cF.imag * cB.imag) / den
    keep = 1.0 - mu * bb / den
    frozen, changes = _learn_frozen(cF, cB, state, gate_db=gate_db, gate_lam=lam if gate_lam is None else gate_lam,
                                    gate_window=gate_window, also_frozen=also_frozen)
    if frozen is not None:
        gain[frozen] = 0.0
        keep[frozen] = 1.0
    if extras is not None:
        extras.update(frozen=frozen, p1=p1)
    betas, b = _clipped_recursion(keep, gain, state.beta)
    values = dict(vars(state))
    values.update(beta=b, p_b=pb[-1].copy(), p_1=p1[-1].copy(), **changes)
    return betas, SubbandState(**values)


def _pending(pend, new, n_ahead: int) -> tuple:
    """The rows waiting for the calibration's judgement followed by the block's, array by array: ``pend``
    (``(D, K)`` each) or, at the stream start, ``n_ahead`` zero placeholder rows (the calibration judges as
    many placeholder frames first, with weight 0), then ``new`` (``(F, K)`` each)."""
    if pend is None:
        pend = tuple(np.zeros((n_ahead,) + a.shape[1:], dtype=a.dtype) for a in new)
    return tuple(np.concatenate([a, b]) for a, b in zip(pend, new))


def _hand_over(quick: np.ndarray, late: np.ndarray, n: np.ndarray, n_full: float, blend: bool) -> np.ndarray:
    """A start-up stand-in ``quick`` handing over to the delayed estimate ``late`` (both ``(F, K)``) as the delayed
    one's learned count ``n (F, K)`` reaches ``n_full``: at once (``blend=False``), or linearly in ``n``.

    >>> import numpy as np
    >>> _hand_over(np.zeros(3), np.ones(3), np.array([0.0, 5.0, 20.0]), 10.0, True).tolist()
    [0.0, 0.5, 1.0]
    >>> _hand_over(np.zeros(3), np.ones(3), np.array([0.0, 5.0, 20.0]), 10.0, False).tolist()
    [0.0, 0.0, 1.0]
    """
    if blend:
        return quick + np.minimum(1.0, n / n_full) * (late - quick)
    return np.where(n >= n_full, late, quick)


def _clipped_recursion(keep: np.ndarray, gain: np.ndarray, w0: np.ndarray):
    """``w[l+1] = clip(w[l] keep[l] + gain[l], 0, 1)`` from ``w[0] = w0``: ``(w[0..F-1] (F, K), w[F])``."""
    out = np.empty(keep.shape)
    w = w0.copy()
    for i in range(keep.shape[0]):  # the clip makes it nonlinear: loop over frames, vectorised over bins
        out[i] = w
        w *= keep[i]
        w += gain[i]
        np.minimum(w, 1.0, out=w)
        np.maximum(w, 0.0, out=w)
    return out, w


def das_mix_step(Yd, D, p1, frozen, state: SubbandState, *, lam: float, eps: float, smooth_bins: int = 0,
                 alpha0: float = 0.0):
    """Per-bin least-squares DAS mix weight: ``Y = Yd - alpha D``, ``alpha`` in ``[0, 1]``.

    ``alpha[l] = clip((S_YD + alpha0 r) / (S_DD + r), 0, 1)``, ``r = eps S_11``, from one-pole
    averages (``lam`` per frame) of ``Re(Yd conj(D))``, ``|D|^2`` and ``P_1`` over the frames
    *before* ``l`` that the beta gate (and the caller's ``frozen``) did not freeze, so neither
    the talker nor the frame itself steers its own weight.

    * The regulariser ``r`` is referenced to the *noise* (``S_11``: the front-mic power of the
      same noise-only frames), not to the current frame: a regulariser ``eps P_1[l]`` grows by
      the talker's level with every syllable and drags ``alpha`` to ``alpha0`` exactly while
      the talker speaks -- noise that switches path with the speech, which a following
      spectral subtraction (minimum statistics) cannot track (measured on the ``phone``
      preset's wind, issue 12).
    * ``alpha0``: the prior, the weight before any noise-only frame (and where the averages
      stay tiny).  ``alpha0 = 1`` starts from the DAS, the path that never amplifies any
      noise re the look direction, 0 from the differential path, 0.5 halfway (the minimax
      choice: the output-noise excess is ``(alpha - alpha*)^2 S_DD`` for the unknown optimum
      ``alpha*`` in ``[0, 1]``).
    * ``smooth_bins`` (``h``): the per-frame products are first averaged over the ``2h + 1``
      neighbouring bins (edges repeated), a least-squares fit over ``2h + 1`` times more
      cells of the same time span.  In incoherent noise ``E[alpha] = 1`` exactly, and the
      clip of a noisy ratio is biased below it; the lower-variance ratio removes most of
      that bias without slowing the adaptation.

    ``state.alpha`` / ``state.p_d`` / ``state.p_m`` carry ``S_YD``, ``S_DD``, ``S_11``.
    Returns ``(alphas (F, K), S_YD, S_DD, S_11)`` (the last three ``(K,)``).
    """
    yd = Yd.real * D.real + Yd.imag * D.imag
    dd = D.real**2 + D.imag**2
    if smooth_bins > 0:
        yd = uniform_filter1d(yd, 2 * smooth_bins + 1, axis=1, mode="nearest")
        dd = uniform_filter1d(dd, 2 * smooth_bins + 1, axis=1, mode="nearest")
    c = np.full(dd.shape, 1.0 - lam) if frozen is None else np.where(frozen, 0.0, 1.0 - lam)
    alphas = np.empty(dd.shape)
    s_yd, s_dd, s_m = state.alpha.copy(), state.p_d.copy(), state.p_m.copy()
    for i in range(dd.shape[0]):  # time-varying one-pole per bin: loop over frames, vectorised over bins
        reg = eps * s_m + TINY
        alphas[i] = (s_yd + alpha0 * reg) / (s_dd + reg)
        s_yd += c[i] * (yd[i] - s_yd)
        s_dd += c[i] * (dd[i] - s_dd)
        s_m += c[i] * (p1[i] - s_m)
    np.clip(alphas, 0.0, 1.0, out=alphas)
    return alphas, s_yd, s_dd, s_m


@dataclass(frozen=True)
class SubbandEbParams(StftParams):
    """NLMS, gate and equaliser fields shared by ``eb-subband`` and ``eb-robust``."""

    mu: float = 0.1
    lam: float = 0.9
    eps: float = 1e-4
    beta0: float = 0.0
    adapt_gate_db: float | None = None
    gate_lam: float | None = None
    gate_floor_s: float = 0.0
    eq: bool = True
    eq_max_gain_db: float = 25.0
    eq_noise_gain_db: float | None = None
    eq_highpass_hz: float = 0.0
    eq_phase: bool = False
    das_mix: bool = False
    mix_lam: float = 0.95
    mix_smooth_bins: int = 0
    mix_alpha0: float = 0.0
    beta_model: str = "bin"
    mix_bands_hz: tuple | None = None
    mix_ramp_cells: float = 0.0
    mix_model: str = "weights"
    mix_fast_cells: float = 0.0
    eq_bound_beta: float | None = None
    beta_lam: float = 0.9
    beta_fast_frames: float = 0.0
    mix_fast_ramp_cells: float | None = None
    fast_blend: bool = False

    def _check_subband(self):
        self._check_stft()
        check_range("mu", self.mu, 0.0, 2.0, lo_open=True, hi_open=True)
        check_range("lam", self.lam, 0.0, 1.0, hi_open=True)
        check_range("eps", self.eps, 0.0, 1.0)
        check_range("beta0", self.beta0, 0.0, 1.0)
        if self.adapt_gate_db is not None:
            check_range("adapt_gate_db", self.adapt_gate_db, -60.0, 60.0)
        if self.gate_lam is not None:
            check_range("gate_lam", self.gate_lam, 0.0, 1.0, hi_open=True)
        check_range("gate_floor_s", self.gate_floor_s, 0.0, 60.0)
        if not isinstance(self.eq, bool):
            raise ParameterError("eq", self.eq, "True or False")
        check_range("eq_max_gain_db", self.eq_max_gain_db, 0.0, 60.0)
        if self.eq_noise_gain_db is not None:
            check_range("eq_noise_gain_db", self.eq_noise_gain_db, -20.0, 60.0)
        check_range("eq_highpass_hz", self.eq_highpass_hz, 0.0, 1000.0)
        check_range("mix_lam", self.mix_lam, 0.0, 1.0, hi_open=True)
        check_int("mix_smooth_bins", self.mix_smooth_bins, minimum=0, maximum=64)
        check_range("mix_alpha0", self.mix_alpha0, 0.0, 1.0)
        self._check_pooling()
        if self.eq_bound_beta is not None:
            check_range("eq_bound_beta", self.eq_bound_beta, 0.0, 1.0)
        if not isinstance(self.eq_phase, bool):
            raise ParameterError("eq_phase", self.eq_phase, "True or False")
        if not isinstance(self.das_mix, bool):
            raise ParameterError("das_mix", self.das_mix, "True or False")
        if self.das_mix and not self.eq_phase:
            raise ParameterError("das_mix", self.das_mix, "das_mix=True only with eq_phase=True (the two paths "
                                 "must share the look phase)")


    def _check_pooling(self):
        check_choice("beta_model", self.beta_model, ("bin", "delayed"))
        check_range("beta_lam", self.beta_lam, 0.0, 1.0, hi_open=True)
        check_range("beta_fast_frames", self.beta_fast_frames, 0.0, 1e9)
        if self.mix_fast_ramp_cells is not None:
            check_range("mix_fast_ramp_cells", self.mix_fast_ramp_cells, 0.0, 1e9)
        if not isinstance(self.fast_blend, bool):
            raise ParameterError("fast_blend", self.fast_blend, "True or False")
        if self.beta_model == "delayed" and not (getattr(self, "calibrate", False) and self.talker_blind):
            raise ParameterError("beta_model", self.beta_model, "'bin' unless eb-robust calibrates "
                                 "(calibrate=True) with the frame rule: the delayed beta learns where the "
                                 "calibration does")
        edges = self.mix_bands_hz
        if edges is not None and (not isinstance(edges, tuple) or any(not isinstance(e, (int, float)) or e <= 0
                                                                       for e in edges)
                                  or list(edges) != sorted(set(edges))):
            raise ParameterError("mix_bands_hz", edges, "a tuple of increasing band edges in Hz (> 0)")
        check_range("mix_ramp_cells", self.mix_ramp_cells, 0.0, 1e9)
        check_choice("mix_model", self.mix_model, ("weights", "delayed"))
        check_range("mix_fast_cells", self.mix_fast_cells, 0.0, 1e9)
        if self.mix_model == "delayed" and not (getattr(self, "calibrate", False) and self.mix_bands_hz is not None):
            raise ParameterError("mix_model", self.mix_model, "'weights' unless eb-robust calibrates (calibrate=True) "
                                 "and mix_bands_hz is set: the delayed weight learns per band where the "
                                 "calibration does")


class SubbandBase(fast_frames.FusedStreaming, StftEnhancer):
    """Sub-band EB on (possibly calibrated) spectra; subclasses may transform the rear mic first."""

    def _gate_window(self, fs: int) -> int:
        p = self.params
        return int(math.ceil(float(p.gate_floor_s) * fs / int(p.hop))) if p.gate_floor_s > 0 else 0

    def _fast_state(self, fs: int, n_bins: int, band: slice | None = None):
        """The compiled step's state (:mod:`enhancers.kernels.frames`), with the calibration when ``band``."""
        return fast_frames.new_state(self.params, fs, n_bins, delay=self.delay_samples(fs),
                                     filterbank=self.filterbank, band=band, gate_window=self._gate_window(fs))

    def _cardioids(self, X1, X2, fs):
        ph = np.exp(-1j * bin_omega(int(self.params.frame_len)) * self.delay_samples(fs))
        return X1 - ph * X2, X2 - ph * X1

    def _eq(self, betas, fs):
        p = self.params
        if not p.eq:
            return np.ones_like(betas)
        n = int(p.frame_len)
        omega = bin_omega(n)
        # eq_bound_beta: the white-noise bound of a fixed pattern, so that the EQ -- which the talker
        # passes through -- does not follow the adapted beta (issue 16: an EQ that moves with beta
        # moves the talker's path with every speech x noise cross term beta learns from)
        bound_betas = betas if p.eq_bound_beta is None else np.full(betas.shape, float(p.eq_bound_beta))
        g = look_eq_gain(bound_betas, omega=omega, delay_samples=self.delay_samples(fs),
                         freqs_hz=omega / (2 * np.pi) * fs, max_gain_db=float(p.eq_max_gain_db),
                         noise_gain_db=None if p.eq_noise_gain_db is None else float(p.eq_noise_gain_db),
                         highpass_hz=float(p.eq_highpass_hz))
        # the look response is 2j sin(wT) e^{-jwT} X1: -j undoes the j (a 90 deg shift, which a
        # time-domain integrator undoes too), leaving the front mic delayed by T
        return -1j * g if p.eq_phase else g + 0j

    def _das(self, X1, X2, G, fs):
        """Delay-and-sum towards the look direction with the differential path's look gain:
        ``|G 2 sin(wT)| (X1 e^{-jwT} + X2) / 2`` (look response = that of ``G (cF - beta cB)``)."""
        wt = bin_omega(int(self.params.frame_len)) * self.delay_samples(fs)
        look = np.abs(G) * np.abs(2.0 * np.sin(wt))
        return look * 0.5 * (X1 * np.exp(-1j * wt) + X2)

    def _betas(self, cF, cB, X1, sub: SubbandState, fs: int, beta_frozen, learn=None):
        """``(betas (F, K), new state, frozen (F, K) or None, smoothed |X1|^2 (F, K))``: one NLMS beta per bin
        (``beta_frozen (F, K)``: more cells where it must not learn, or None), or (``beta_model="delayed"``)
        one least-squares beta per bin, learned with the calibration's weights ``learn``."""
        p = self.params
        gate_db = None if p.adapt_gate_db is None else float(p.adapt_gate_db)
        gate_lam = float(p.lam) if p.gate_lam is None else float(p.gate_lam)
        if p.beta_model == "delayed":
            return self._delayed_betas(cF, cB, X1, sub, fs, learn, gate_db=gate_db, gate_lam=gate_lam)
        extras: dict = {}
        betas, sub = subband_beta_step(cF, cB, X1, sub, mu=float(p.mu), lam=float(p.lam), eps=float(p.eps),
                                       gate_db=gate_db, gate_lam=gate_lam, gate_window=self._gate_window(fs),
                                       extras=extras, also_frozen=beta_frozen)
        return betas, sub, extras["frozen"], extras["p1"]

    def _delayed_betas(self, cF, cB, X1, sub: SubbandState, fs: int, learn, *, gate_db, gate_lam):
        """``beta_model="delayed"``: one least-squares beta per bin, ``clip(S_FB / S_BB, 0, 1)`` (``beta0`` before
        any frame is learned; :func:`enhancers.beam.beam_pool.pooled_mix_step` with one band per bin: the minimiser
        of ``|cF - beta cB|^2`` over the frames learned, one-pole ``beta_lam`` per frame), learned ``D`` frames
        late like ``mix_model="delayed"``: the block's cardioids wait in ``sub.beta_pend`` until the
        calibration's held weights (``learn = (held, now)``) judge them, the talker's onset after them known.

        Why least squares and not the NLMS of ``"bin"``: an NLMS updated with a ``D``-frame-old error is
        stable only for a normalised step ``mu < ~pi / (4 D)`` (0.026 at ``D = 30``); a ratio of averages has
        no feedback, so the delay costs only ``D`` frames of lag.  The own gate (``adapt_gate_db``), judged
        on the block's frames, waits with them and multiplies the weights (the stream's first ~11 frames stay
        out of it and are learned ungated).  ``beta_fast_frames > 0``: until a
        bin has learned that many (weighted) frames, a beta learned at once on ``now`` -- the frames before
        the frame rule first hears the talker -- stands in (a stream starts on the noise).
        Returns as :meth:`_betas`."""
        p = self.params
        F, K = cF.shape
        # the stream's first frames stay out of the gate: the filter bank's first frame holds part of a window
        # of signal (not learned either), and the gate's smoother starts from zero powers, so for about
        # 1 / (1 - gate_lam) frames its ratio is one frame's -- a single low one would set the floor for
        # gate_floor_s (measured: a plane wave's first frames up to 10 dB below the rest, beta frozen for
        # 1.2 s).  Those frames are learned ungated: the start matters (a machine already running).
        n_part = max(0, int(p.frame_len) // int(p.hop) - 1 - sub.frames)
        n_start = int(p.frame_len) // int(p.hop) - 1 + int(round(1.0 / (1.0 - gate_lam)))
        m = min(F, max(0, n_start - sub.frames))
        frozen, changes = None, {}
        if F > m:  # (the gate needs frames)
            frozen, changes = _learn_frozen(cF[m:], cB[m:], sub, gate_db=gate_db, gate_lam=gate_lam,
                                            gate_window=self._gate_window(fs), also_frozen=None)
        if gate_db is not None:
            start = np.zeros((m, K), dtype=bool)
            start[:n_part] = True
            frozen = np.concatenate([start, frozen if frozen is not None else np.zeros((0, K), dtype=bool)])
        p1 = smooth_frames(X1.real**2 + X1.imag**2, float(p.lam), sub.p_1) if F else np.zeros((0, K))
        open_ = np.ones((F, K)) if frozen is None else (~frozen).astype(float)
        n_ahead = p.look_ahead_frames(fs)  # (eb-robust's calibration parameters)
        fs_, bs_, ps_, os_ = _pending(sub.beta_pend, (cF, cB, p1, open_), n_ahead)
        held, now = learn
        zeros = [np.zeros(K)] * 4
        # no regulariser (eps 0): the ratio is the minimiser itself, as NLMS's fixed point is; a regulariser
        # re |X1|^2 would pull beta towards beta0 where the backward cardioid is weak (low frequencies)
        kw = dict(onehot=None, lam=float(p.beta_lam), eps=0.0, alpha0=float(p.beta0))
        st = zeros if sub.beta_ls is None else list(sub.beta_ls)
        learned = held * os_[:F]
        values = dict(vars(sub))
        betas, *st = pooled_mix_step(fs_[:F], bs_[:F], ps_[:F], learned, *st, **kw)
        if p.beta_fast_frames > 0:  # the start: a beta learned at once stands in until the delayed one has frames
            n_before = (0.0 if sub.beta_ls is None else sub.beta_ls[3]) + np.cumsum(learned, axis=0) - learned
            fast = zeros if sub.beta_fast is None else list(sub.beta_fast)
            # the block's own frames, learned at once with the block's weights
            quick, *fast = pooled_mix_step(fs_[n_ahead:], bs_[n_ahead:], ps_[n_ahead:], now * os_[n_ahead:], *fast,
                                           **kw)
            betas = _hand_over(quick, betas, n_before, float(p.beta_fast_frames), p.fast_blend)
            values["beta_fast"] = tuple(fast)
        values.update(beta_ls=tuple(st), beta_pend=tuple(a[F:] for a in (fs_, bs_, ps_, os_)),
                      p_1=p1[-1].copy() if F else sub.p_1, beta=betas[-1].copy() if F else sub.beta, **changes)
        return betas, SubbandState(**values), frozen, p1

    def _mix(self, Y, D, p1, frozen, sub: SubbandState, fs: int, mix_learn=None):
        """``(alphas (F, K), new state)``: the DAS mix weight per bin or (``mix_bands_hz``) per band, or
        (``mix_model="delayed"``) learned with the caller's weights ``mix_learn``, which lag the block."""
        p = self.params
        if p.mix_model == "delayed":
            return self._delayed_mix(Y, D, p1, sub, fs, mix_learn)
        if p.mix_bands_hz is None:
            alphas, a, pd, pm = das_mix_step(Y, D, p1, frozen, sub, lam=float(p.mix_lam), eps=float(p.eps),
                                             smooth_bins=int(p.mix_smooth_bins), alpha0=float(p.mix_alpha0))
            changes = dict(alpha=a, p_d=pd, p_m=pm)
        else:
            onehot = band_onehot(bin_omega(int(p.frame_len)) / (2 * np.pi) * fs, p.mix_bands_hz)
            st = [np.zeros(onehot.shape[1])] * 4 if sub.mix_n is None else [sub.alpha, sub.p_d, sub.p_m, sub.mix_n]
            alphas, *st = pooled_mix_step(Y, D, p1, None if frozen is None else ~frozen, *st, onehot=onehot,
                                          lam=float(p.mix_lam), eps=float(p.eps), alpha0=float(p.mix_alpha0),
                                          ramp_cells=float(p.mix_ramp_cells))
            changes = dict(zip(("alpha", "p_d", "p_m", "mix_n"), st))
        values = dict(vars(sub))
        values.update(changes)
        return alphas, SubbandState(**values)

    def _delayed_mix(self, Y, D, p1, sub: SubbandState, fs: int, learn):
        """``mix_model="delayed"``: the pooled weight (:func:`enhancers.beam.beam_pool.pooled_mix_step`) learned from
        the frames the caller's held weights judge, which lag the block by ``D`` frames (the calibration's
        look ahead): the block's products wait ``D`` frames in ``sub.mix_pend``, so a frame is learned only
        once the talker's onset ``D`` frames after it is known.  The weight of a frame uses the frames
        learned before it (``D`` frames older: a slowly varying weight loses nothing).  ``learn = (held (F,
        K), now (F, K))``: the weights of the frames reached now and of the block's own frames, on which the
        start-up weight learns at once (``mix_fast_cells``)."""
        p = self.params  # (the parameter check admits "delayed" only where eb-robust's calibration gives learn)
        F = Y.shape[0]
        n_ahead = p.look_ahead_frames(fs)  # (eb-robust's calibration parameters)
        ys, ds, ps = _pending(sub.mix_pend, (Y, D, p1), n_ahead)
        onehot = band_onehot(bin_omega(int(p.frame_len)) / (2 * np.pi) * fs, p.mix_bands_hz)
        held, now = learn
        zeros = [np.zeros(onehot.shape[1])] * 4
        st = zeros if sub.mix_n is None else [sub.alpha, sub.p_d, sub.p_m, sub.mix_n]
        kw = dict(onehot=onehot, lam=float(p.mix_lam), eps=float(p.eps), alpha0=float(p.mix_alpha0))
        alphas, *st = pooled_mix_step(ys[:F], ds[:F], ps[:F], held, *st, ramp_cells=float(p.mix_ramp_cells), **kw)
        values = dict(vars(sub))
        if p.mix_fast_cells > 0:  # the start: the weight learned at once stands in until the delayed one has cells
            cells = held @ onehot  # (F, B); n_before: the cells the delayed weight learned before each frame
            n_before = (0.0 if sub.mix_n is None else sub.mix_n) + np.cumsum(cells, axis=0) - cells
            fast = zeros if sub.mix_fast is None else list(sub.mix_fast)
            ramp_q = p.mix_ramp_cells if p.mix_fast_ramp_cells is None else p.mix_fast_ramp_cells
            # the block's own frames, learned at once with the block's weights
            quick, *fast = pooled_mix_step(ys[n_ahead:], ds[n_ahead:], ps[n_ahead:], now, *fast,
                                           ramp_cells=float(ramp_q), **kw)
            band = onehot.argmax(axis=1)
            alphas = _hand_over(quick, alphas, n_before[:, band], float(p.mix_fast_cells), p.fast_blend)
            values["mix_fast"] = tuple(fast)
        values.update(zip(("alpha", "p_d", "p_m", "mix_n"), st), mix_pend=(ys[F:], ds[F:], ps[F:]))
        return alphas, SubbandState(**values)

    def _beamform(self, X1, X2, sub: SubbandState, fs: int, mix_frozen=None, beta_frozen=None, mix_learn=None):
        """``(Y (F, K), record, new state)`` for the frames of one block.

        ``mix_frozen`` (F, K): bins where the DAS mix weight must not learn either (OR-ed with the gate);
        ``beta_frozen`` (F, K): the same for beta; ``mix_learn``: ``mix_model="delayed"``'s pair of weights
        from eb-robust's calibration (see :meth:`_delayed_mix`).
        """
        p = self.params
        cF, cB = self._cardioids(X1, X2, fs)
        betas, sub, frozen, p1 = self._betas(cF, cB, X1, sub, fs, beta_frozen, learn=mix_learn)
        G = self._eq(betas, fs)
        Y = G * (cF - betas * cB)
        record = {"beta": betas, "eq": G}
        if p.das_mix and Y.shape[0]:
            D = Y - self._das(X1, X2, G, fs)
            if mix_frozen is not None:
                frozen = mix_frozen if frozen is None else (frozen | mix_frozen)
            alphas, sub = self._mix(Y, D, p1, frozen, sub, fs, mix_learn=mix_learn)
            Y = Y - alphas * D
            record["alpha"] = alphas
        return Y, record, dataclasses.replace(sub, frames=sub.frames + X1.shape[0])

    def _apply_beam(self, X1, X2, record, fs):
        cF, cB = self._cardioids(X1, X2, fs)
        G = record["eq"]
        Y = G * (cF - record["beta"] * cB)
        if "alpha" in record:
            Y = Y - record["alpha"] * (Y - self._das(X1, X2, G, fs))
        return Y


class SubbandElkoBeamformer(SubbandBase):
    """Elko's adaptive differential beamformer with one NLMS beta per STFT bin (see module docstring).

    Parameters (``SubbandElkoBeamformer.Params``)
    ---------------------------------------------
    spacing_m, c_mps : pair spacing (m) and speed of sound (m/s).
    frame_len, hop, window : WOLA filter bank (default 256 / 128 / Hamming = 16 ms, 50 % at 16 kHz).
    mu : NLMS step per frame, ``0 < mu < 2`` (default 0.1).
    lam : smoothing of the normalising powers per frame, ``[0, 1)`` (default 0.9 = 80 ms at 8 ms hops).
    eps : regularisation relative to the front-mic power (default 1e-4).
    beta0 : initial beta of every bin in ``[0, 1]`` (default 0: forward cardioid).
    adapt_gate_db, gate_lam, gate_floor_s : the per-bin adaptation gate (None = off, default).
    eq, eq_max_gain_db, eq_noise_gain_db, eq_highpass_hz : equaliser (:mod:`enhancers.core.eq`).
    eq_phase : undo the look response's 90-degree shift (default off; see the module docstring).
    das_mix, mix_lam : the DAS fallback (off by default; needs ``eq_phase``) and its averages' factor
        per frame (0.95).
    mix_smooth_bins, mix_alpha0 : the DAS mix weight's averaging half-width over bins (default 0) and
        its prior (default 0: the differential path); see :func:`das_mix_step`.
    beta_model : ``"bin"`` (default: one NLMS beta per bin) or ``"delayed"`` (``eb-robust`` with the frame rule
        only: one least-squares beta per bin learned ``level_ahead_s`` late on the calibration's held weights,
        see ``_delayed_betas``).
    beta_lam, beta_fast_frames : ``"delayed"``'s average factor per learned frame (0.9) and its start-up
        stand-in's length in learned frames per bin (0: none).
    fast_blend : the stand-ins (``mix_fast_cells``, ``beta_fast_frames``) hand over to the delayed estimates
        linearly in the learned count (``quick + min(1, n / N) (delayed - quick)``) instead of at once at ``N``
        (default False): the count differs a little between the runs on ``s + n`` and ``s - n``, and a switch
        at a count changes the weight by the two estimates' whole difference in one run only.
    mix_fast_ramp_cells : the DAS weight's stand-in's own shrinkage towards ``mix_alpha0`` (cells; default
        None: ``mix_ramp_cells``, as the delayed weight's).
    eq_bound_beta : the EQ's noise-aware bound from the fixed pattern ``cF - b cB`` (None, default: from the
        adapted beta; see the module docstring).
    mix_bands_hz, mix_ramp_cells : the DAS mix weight per band (edges in Hz, ``()``: one band; default
        None: per bin) from the band's unfrozen cells only, shrunk towards ``mix_alpha0`` until it has
        learned ``mix_ramp_cells`` cells (default 0: no shrinkage); :func:`enhancers.beam.beam_pool.pooled_mix_step`.
    mix_model, mix_fast_cells : ``"weights"`` (default: the weight learns at once, where its masks leave a
        cell open) or ``"delayed"`` (``eb-robust`` only, with ``mix_bands_hz``: learned ``level_ahead_s``
        late, with the calibration's weights -- the talker's onset is known before a frame is learned);
        with ``mix_fast_cells > 0`` the weight learned at once -- on the frames before the frame rule first
        hears the talker -- stands in for the delayed one until it has that many cells of a band (a stream
        starts on the noise; the delayed weight has nothing for its first ``level_ahead_s``).

    Examples
    --------
    >>> import numpy as np, enhancers
    >>> e = enhancers.make("eb-subband")
    >>> y = e.process(np.random.default_rng(0).standard_normal((2, 16000)), 16000).output
    >>> y.shape
    (1, 16000)
    """

    name: ClassVar[str] = "eb-subband"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "Elko adaptive differential beamformer with one NLMS beta per STFT bin"

    @dataclass(frozen=True)
    class Params(SubbandEbParams):
        def __post_init__(self):
            self._check_subband()

    def _algo_init(self, fs, n_bins):
        if fast_frames.COMPILED and fast_frames.kernel_supports(self.params):
            return self._fast_state(fs, n_bins)
        return subband_init(n_bins, float(self.params.beta0))

    def _frames(self, X, algo, fs):
        if isinstance(algo, fast_frames.FastState):  # the compiled step (enhancers.kernels.frames)
            Y, record = algo.frames(X)
            return Y[None], algo, record
        Y, record, algo = self._beamform(X[0], X[1], algo, fs)
        return Y[None], algo, record

    def _apply(self, record, X, fs):
        return self._apply_beam(X[0], X[1], record, fs)[None]

    def _trace(self, record):
        return {k: record[k] for k in ("beta", "alpha") if k in record}
