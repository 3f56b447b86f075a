"""Self-calibration of the rear microphone against the front one, per STFT bin (``"mic-calibration"``).

Model: the rear mic's signal is its ideal signal times an unknown, slowly varying complex
response ``r(f)`` relative to the front mic (sensitivity, phase, unequal high-pass corners:
algorithms.md section 4b).  The stage estimates ``r`` per bin from what a phone has
-- noise reaching both mics from the far field or diffusely -- and outputs
``[X1, X2 / r_hat]`` (2 channels).

Estimator.  Per bin, one-pole averages that move only where the bin is not frozen::

    S11 = <|X1|^2>,   S22 = <|X2|^2>,   S21 = <X2 conj(X1)>
    S[l] = S[l-1] + (1 - lam) (x[l] - S[l-1])   (active bins),   S[l] = S[l-1]   (frozen bins)

with ``lam = exp(-hop / (fs tau_s))``: **time constant ``tau_s`` (default 1 s) of active
time**.  To converge quickly from the start, the step of a bin's ``n``-th active frame is
``max(1/n, 1 - lam)``: a plain running mean of everything seen until ``n`` reaches
``~tau_s fs / hop`` frames (125), the one-pole after that.  Measured convergence in white
diffuse noise with 1 dB / 5 deg / corners 80 and 120 Hz (the freeze rule below holds ~78 %
of the bins there), worst bin from 200 Hz to 4 kHz: 0.8 dB / 7 deg after 1 s, 0.5 dB /
3 deg after 4 s, 0.25 dB / 2.5 deg after 8 s.  A talker's frozen frames only delay it.

* Gain: for a far-field source and for a diffuse field both mics receive the same
  power, so ``|r| = sqrt(S22 / S11)`` (near-field sources break this: see the freeze rule).
* Phase: for a diffuse field ``S21 = r S sinc(2 f d / c)`` with a real, positive sinc
  (below ``c / 2d``, 8 kHz for 2.14 cm), so ``angle(S21) = angle(r)``.  A far-field source
  from ``theta`` adds the propagation phase ``-w T cos(theta)``, linear in frequency, while
  a mismatch phase is not (constant, or ~1/f from unequal high-pass corners).  So per
  frame the slope ``b`` (rad per bin) of ``angle(S21)`` over ``fit_band_hz`` (default
  500-4000 Hz) is estimated -- a lag-one product across bins for a first guess, refined by a
  weighted least-squares fit of ``a + b k + c / k`` (the ``c / k`` term takes up unequal
  high-pass corners, which would otherwise bias ``b``) -- clipped to the physical range
  ``|b| <= 2 pi T fs / N`` and removed: ``phi_k = angle(S21[k] e^{-j b k})``.  From a single
  far-field source alone the mismatch's *linear-in-frequency* part cannot be told apart
  from the direction (the issue's point); the separation rests on the mismatch having no
  such part (a pure delay between the mics is not in the sensor model), and it is exact
  for a constant phase offset.
* Both are averaged over the bins ``k +- max(smooth_bins, round(smooth_frac k))`` (bands
  widening with frequency, ~1/6 octave by default, where diffuse noise is less coherent
  and the phase estimate noisier), clipped to ``+-max_gain_db`` and ``+-max_phase_deg``:
  ``r_hat = |r| e^{j phi}``.
* Where the band-averaged coherence ``|S21| / sqrt(S11 S22)`` is below ``min_coherence``
  (0.3) the phase has nothing to measure -- incoherent noise (wind, self-noise), or diffuse
  noise above ~5.5 kHz for 2.14 cm -- so the last measured phase is kept, times
  ``phase_leak`` (0.98) per update (a 1.6 s fade towards 0, so that a phase seen by chance
  in the first frames does not stay): without this rule incoherent noise walks it to the
  +-30 deg clip.  The gain needs no
  coherence (equal powers hold for incoherent noise of equal level too).

Freeze rule (frozen while near-field speech dominates).  The talker is in front of the
phone (near field at the mouth, or far field in the look half plane); its gain ratio is
not 1 in the near field and its propagation phase would be mistaken for mismatch, so the
averages stop while it dominates.  From the *uncalibrated* forward/backward cardioids
``cF``, ``cB``: ``q = 10 log10(P_F / P_B)`` with one-pole smoothed powers (``gate_lam_cal``
per frame, default 0.7 = 27 ms: fast enough to catch syllable onsets, whose leakage
otherwise dominates the error); diffuse noise gives ~0 dB, a rear source < 0 dB, a frontal
talker > 0 dB.  Frozen where ``q > min(floor, 0) + threshold`` (``floor``: running minimum of
``q`` over ``floor_s`` = 1 s, the rule of ``eb-gated``), by either of two rules:

* per bin, from the powers of the bin's neighbours 2 and 3 bins away (``freeze_db``, 2 dB);
* for the band ``fit_band_hz`` (``freeze_band_db``, 1 dB), its sums leaving out the bin and
  its two neighbours; this rule reaches the low bins, where a mismatch pulls every source's
  ratio towards 0 dB so that they cannot see the talker by themselves.

Why not the bin's own ratio: ``|cF|^2 - |cB|^2 = 4 sin(w T) Im(X2 conj(X1))``, so selecting
frames by it selects on the very cross-spectrum being estimated and biases the phase
(measured in diffuse noise: 6-7 deg at 1-4 kHz); the neighbours' noise is nearly
independent of the bin's.  The price of a floor-relative rule: in stationary diffuse noise
the ratio fluctuates above its 1-s minimum, so ~75 % of the bins are frozen and the
estimate converges ~4x more slowly than ``tau_s``.  While frozen, ``r_hat`` holds.  The decisions do not depend on ``r_hat``, so
they are vectorised; the averages are a loop over frames vectorised over bins.
``r_hat`` is recomputed from the averages every ``estimate_every`` frames (default 4 = 32
ms, counted from the stream start; it moves with time constant ``tau_s`` anyway) and
includes that frame; the frames in between use the last one.

Measured (tests/test_mic_calibration.py; 1 dB, 5 deg, high-pass corners 80/120 Hz, 8 s of
white noise, per-bin worst case): in diffuse noise 0.17 dB / 1.1 deg from 100 Hz to 1 kHz,
0.25 dB / 2.2 deg to 4 kHz; one far-field plane wave at 135 or 240 deg 0.17 dB / 1 deg from
100 Hz to 7 kHz; a near-field talker at +10 dB for 4 s moves it by 0.06 dB / 0.5 deg.

Talker-blind rules (off by default; ``eb-robust-blind``'s settings are
:data:`enhancers.beam.presets.EB_ROBUST_BLIND`).  The cardioid rules above leave cells open while the talker
speaks within 1-2 dB of its ratio's floor, and at 15-25 dB input those cells carry the talker x noise cross
term, which changes sign with the noise: the estimate then differs between Hagerman's runs on ``s + n`` and
``s - n``.  Where the talker is absent the two mixtures are the same up to sign, so rules that learn only
there give both runs the same estimate:

* the frame rule (``frame_q_db``): ``q = 10 log10(P_F / P_B)`` of the band sums over ``frame_band_hz``
  (and, with ``frame_low_hz``, over ``frame_low_hz``-``frame_band_hz[0]`` judged on its own), smoothed by
  ``gate_lam_cal``; a frame with ``q >= frame_q_db`` in any band is the talker's (weight 0, else 1), and
  so is one whose band power is ``frame_level_db`` over its running minimum over ``level_floor_s``.  The
  decisions of the first ``frame_start_s`` are not trusted (weight 1).  Each frame's weight is the
  minimum over ``level_hang_s`` before it and ``level_ahead_s`` after it (the averages run that far
  behind the input), with edges tapered over ``frame_hold_taper_s`` (:func:`_held`);
* the SNR share (``frame_snr_db = (lo, hi)``): from the estimated input SNR (one-pole band powers of the
  talker's and the other frames, :func:`_frame_snr_share`) the weights move linearly from the cardioid
  rules' (below ``lo`` dB: the noise masks the talker) to the frame rule's (above ``hi``);
* the rear rule (``cal_rear_db``): a cell whose *calibrated* backward/forward cardioid ratio (the powers
  of the bins :data:`LEVEL_NEAR` away, the estimate of the last ``cal_chunk``-frame chunk applied) is
  over ``cal_rear_db`` is learned in a talker's frame too -- graded over ``cal_rear_soft_db``, on a
  smoother ``cal_rear_lam``, with ``cal_rear_low_db`` taking the share's place at low SNR
  (:func:`_rear_weight`);
* the start-up ramp (``ramp_frames``): while a bin has ``n`` active frames the applied estimate is
  ``r^min(1, n / ramp_frames)``; and the sensor model (``model="hp1"``,
  :mod:`enhancers.beam.calibration_model`), 4 parameters fitted over ``model_band_hz`` instead of per-bin
  averages.

Measured (tests/test_mic_calibration.py): with the frame rule the estimates of the runs on ``s + n`` and
``s - n`` are identical through a talker burst.  ``eb-robust-blind`` on ``phone`` at >= 15 dB input keeps
``speech_jitter_db`` below -30 dB on seeds 0-4 but not on seeds 5-9 (6 of 60 rows above -30 dB on the
built-in data, 7 of 60 on ``../shared/data``; ``python -m benchmarks.studies.calibration_jitter --blind
--first-seed 5``), at 13x ``eb-robust``'s cost; :mod:`enhancers.beam.spp_eb` estimates the same response
from an SPP-weighted noise covariance.

``trace``: ``"rear_gain_db"``, ``"rear_phase_deg"`` (``(n_frames, n_bins)``, the applied
estimate) and ``"frozen"`` (``(n_frames, n_bins)``, 1.0 where the current frame is frozen --
without the frame rule's look ahead: the mask the DAS weight uses).
Latency ``frame_len - 1`` samples.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.beam.calibration_model import fit_hp1, hp1_log_response
from enhancers.core.stft_stage import (
    TINY,
    GateState,
    StftEnhancer,
    StftParams,
    bin_omega,
    gate_init,
    power_ratio_gate,
    smooth_frames,
)
from enhancers.kernels import frames as fast_frames
from scenesim.errors import ParameterError
from scenesim.validate import check_int, check_range

__all__ = ["CalibrationState", "MicCalibration", "calibration_step"]

# the rear rule measures a bin from its neighbours LEVEL_NEAR bins away (not the bin itself: selecting on a
# cell's own power would bias its averages), so a talker-free bin of a talker frame still learns
LEVEL_NEAR = (-4, -3, -2, 2, 3, 4)
# what r_hat is: "bins", smoothed per-bin averages; "hp1", the 4-parameter sensor model fitted over model_band_hz
MODELS = ("bins", "hp1")


@dataclass(frozen=True)
class CalibrationState:
    """Streaming state: averages ``(3, K)`` (S11, S22, S21), the rules' smoothers and floor histories."""

    avg: np.ndarray          # complex (3, K)
    r_last: np.ndarray       # complex (K,) the estimate of the last update frame (as applied)
    raw_last: np.ndarray     # complex (K,) the same before the shrinkage towards 1
    n_frames: int            # frames processed so far (decides the update frames)
    counts: np.ndarray       # (K,) active frames so far per bin (the running-mean start)
    q_bin: GateState         # the per-bin freeze rule's state
    q_band: GateState        # the band freeze rule's state
    pend_x: np.ndarray       # complex (D, 3, K): the last D frames' products, not yet averaged
    pend_card: np.ndarray    # bool (D, K): their cardioid-rule decisions
    r_dir: np.ndarray        # complex (K,) the estimate the rear rule applies (the last chunk start's)
    q_rear: GateState | None = None  # the rear rule's smoothed cardioid powers (cal_rear_db)
    pend_rear: np.ndarray | None = None  # bool (D, K): the rear rule's decisions of the pending frames (uint8
    #                                       levels 0 / 1 / 2 with cal_rear_low_db)
    theta: np.ndarray | None = None  # (4,) model="hp1": the last fit (calibration_model), None: the prior
    q_frame: GateState | None = None  # the frame rule's smoothed band cardioid powers (frame_q_db), (1,)
    w_tail: np.ndarray | None = None  # (H + D,) the frame rule's weights of the frames before the block
    p_tail: np.ndarray | None = None  # (D,) frame_snr_quiet: the band powers of the last D frames (NaN: none yet)
    snr: np.ndarray | None = None  # (4,) frame_snr_db: band power of talker / other frames and their counts
    q_frame_level: GateState | None = None  # frame_level_db: the frame's smoothed band power and its floor, (1,)
    heard: bool = False  # the frame rule has weighed a frame below 1 (the talker was heard) since the stream start
    t_tail: np.ndarray | None = None  # (H + D,) frame_snr_quiet_ratio: the ratio rule's talker flags before the block


@dataclass(frozen=True)
class CalibrationParams(StftParams):
    """Fields of the calibration estimator (shared by ``mic-calibration`` and ``eb-robust``)."""

    tau_s: float = 1.0
    fit_band_hz: tuple[float, float] = (500.0, 4000.0)
    smooth_bins: int = 1
    smooth_frac: float = 0.06
    estimate_every: int = 4
    max_gain_db: float = 6.0
    max_phase_deg: float = 30.0
    min_coherence: float = 0.3
    phase_leak: float = 0.98
    freeze_db: float = 2.0
    freeze_band_db: float = 1.0
    gate_lam_cal: float = 0.7
    floor_s: float = 1.0
    level_floor_s: float = 3.0
    level_hang_s: float = 0.1
    level_ahead_s: float = 0.1
    ramp_frames: float = 0.0
    cal_chunk: int = 8
    cal_rear_db: float | None = None
    cal_rear_low_db: float | None = None
    model: str = "bins"
    model_band_hz: tuple[float, float] = (100.0, 4000.0)
    model_iter: int = 3
    model_prior: float = 1000.0
    model_robust: float | None = 0.05
    frame_q_db: float | None = None
    frame_band_hz: tuple[float, float] = (1000.0, 4000.0)
    frame_snr_db: tuple | None = None
    frame_low_hz: float | None = None
    frame_level_db: float | None = None
    frame_start_s: float = 0.0
    frame_snr_frames: float = 0.0
    frame_snr_low_hz: float | None = None
    frame_snr_quiet_ratio: bool = False
    frame_snr_quiet: bool = False
    frame_snr_clip_db: float | None = None
    frame_hold_taper_s: float = 0.0
    cal_rear_soft_db: float = 0.0
    cal_rear_lam: float | None = None

    @property
    def talker_blind(self) -> bool:
        """True when the frame rule (the talker-blind mode) is on."""
        return self.frame_q_db is not None

    def look_ahead_frames(self, fs: int) -> int:
        """``D``: the frames the talker-blind averages run behind the input (``level_ahead_s``; 0 without it)."""
        return int(round(float(self.level_ahead_s) * fs / int(self.hop))) if self.talker_blind else 0

    def _check_calibration(self):
        self._check_stft()
        check_range("tau_s", self.tau_s, 0.0, 600.0, lo_open=True)
        _check_band("fit_band_hz", self.fit_band_hz)
        check_int("smooth_bins", self.smooth_bins, minimum=0, maximum=64)
        check_range("smooth_frac", self.smooth_frac, 0.0, 1.0)
        check_int("estimate_every", self.estimate_every, minimum=1, maximum=1000)
        check_range("max_gain_db", self.max_gain_db, 0.0, 40.0)
        check_range("max_phase_deg", self.max_phase_deg, 0.0, 180.0)
        check_range("min_coherence", self.min_coherence, 0.0, 1.0)
        check_range("phase_leak", self.phase_leak, 0.0, 1.0)
        check_range("freeze_db", self.freeze_db, -60.0, 60.0)
        check_range("freeze_band_db", self.freeze_band_db, -60.0, 60.0)
        check_range("gate_lam_cal", self.gate_lam_cal, 0.0, 1.0, hi_open=True)
        check_range("floor_s", self.floor_s, 0.0, 60.0)
        check_range("level_floor_s", self.level_floor_s, 0.0, 60.0, lo_open=True)
        check_range("level_hang_s", self.level_hang_s, 0.0, 10.0)
        check_range("level_ahead_s", self.level_ahead_s, 0.0, 10.0)
        check_range("ramp_frames", self.ramp_frames, 0.0, 1e6)
        check_int("cal_chunk", self.cal_chunk, minimum=1, maximum=10000)
        if self.cal_rear_db is not None:
            check_range("cal_rear_db", self.cal_rear_db, 0.0, 60.0)
        if self.cal_rear_low_db is not None:  # a second, lower threshold where the input SNR is low
            if self.cal_rear_db is None or self.frame_q_db is None or self.frame_snr_db is None:
                raise ParameterError("cal_rear_low_db", self.cal_rear_low_db,
                                     "None unless cal_rear_db, frame_q_db and frame_snr_db are set")
            check_range("cal_rear_low_db", self.cal_rear_low_db, 0.0, float(self.cal_rear_db))
        if self.model not in MODELS:
            raise ParameterError("model", self.model, " or ".join(map(repr, MODELS)))
        _check_band("model_band_hz", self.model_band_hz)
        check_int("model_iter", self.model_iter, minimum=1, maximum=100)
        check_range("model_prior", self.model_prior, 0.0, 1e9, lo_open=True)
        if self.model_robust is not None:
            check_range("model_robust", self.model_robust, 0.0, 10.0, lo_open=True)
        if self.frame_q_db is not None:
            check_range("frame_q_db", self.frame_q_db, -60.0, 60.0)
        _check_band("frame_band_hz", self.frame_band_hz)
        if not isinstance(self.frame_snr_quiet, bool):
            raise ParameterError("frame_snr_quiet", self.frame_snr_quiet, "True or False")
        if self.frame_level_db is not None:
            check_range("frame_level_db", self.frame_level_db, 0.0, 60.0, lo_open=True)
        check_range("frame_start_s", self.frame_start_s, 0.0, 10.0)
        check_range("frame_snr_frames", self.frame_snr_frames, 0.0, 1e6)
        if not isinstance(self.frame_snr_quiet_ratio, bool) or (self.frame_snr_quiet_ratio and not self.frame_snr_quiet):
            raise ParameterError("frame_snr_quiet_ratio", self.frame_snr_quiet_ratio,
                                 "True or False (True only with frame_snr_quiet=True: it picks that estimate's frames)")
        if self.frame_snr_clip_db is not None:
            check_range("frame_snr_clip_db", self.frame_snr_clip_db, 0.0, 60.0, lo_open=True)
        check_range("cal_rear_soft_db", self.cal_rear_soft_db, 0.0, 60.0)
        if self.cal_rear_soft_db > 0 and (self.cal_rear_db is None or self.frame_q_db is None):
            raise ParameterError("cal_rear_soft_db", self.cal_rear_soft_db,
                                 "0 unless cal_rear_db and frame_q_db are set (it grades the rear rule's weights)")
        if self.cal_rear_lam is not None:
            check_range("cal_rear_lam", self.cal_rear_lam, 0.0, 1.0, hi_open=True)
            if self.cal_rear_soft_db <= 0:
                raise ParameterError("cal_rear_lam", self.cal_rear_lam,
                                     "None unless cal_rear_soft_db > 0 (it smooths the graded rear rule's ratio)")
        # the taper's last frames lie inside the look ahead (rounding to frames keeps the order)
        check_range("frame_hold_taper_s", self.frame_hold_taper_s, 0.0, float(self.level_ahead_s))
        if self.frame_snr_low_hz is not None:
            check_range("frame_snr_low_hz", self.frame_snr_low_hz, 0.0, float(self.frame_band_hz[0]), hi_open=True)
        if self.frame_low_hz is not None:
            check_range("frame_low_hz", self.frame_low_hz, 0.0, float(self.frame_band_hz[0]), hi_open=True)
        if self.frame_snr_db is not None:
            if not (isinstance(self.frame_snr_db, tuple) and len(self.frame_snr_db) == 2):
                raise ParameterError("frame_snr_db", self.frame_snr_db, "a pair (lo_db, hi_db)")
            lo = check_range("frame_snr_db", self.frame_snr_db[0], -100.0, 100.0)
            check_range("frame_snr_db", self.frame_snr_db[1], lo, 100.0, lo_open=True)


def _check_band(name: str, band) -> None:
    if not (isinstance(band, tuple) and len(band) == 2):
        raise ParameterError(name, band, "a pair (lo_hz, hi_hz)")
    lo = check_range(name, band[0], 0.0, 1e5)
    check_range(name, band[1], lo, 1e5, lo_open=True)


def calibration_init(n_bins: int) -> CalibrationState:
    return CalibrationState(avg=np.zeros((3, n_bins), dtype=complex), r_last=np.ones(n_bins, dtype=complex),
                            raw_last=np.ones(n_bins, dtype=complex), n_frames=0, counts=np.zeros(n_bins),
                            q_bin=gate_init(n_bins), q_band=gate_init(n_bins),
                            pend_x=np.zeros((0, 3, n_bins), dtype=complex), pend_card=np.zeros((0, n_bins), dtype=bool),
                            r_dir=np.ones(n_bins, dtype=complex))


def _band(p: CalibrationParams, fs: int, band_hz: tuple[float, float] | None = None) -> slice:
    """Bins of ``band_hz`` (default ``fit_band_hz``), at least two, DC and Nyquist left out."""
    n = int(p.frame_len)
    lo_hz, hi_hz = p.fit_band_hz if band_hz is None else band_hz
    k_lo = max(1, int(math.ceil(lo_hz * n / fs)))
    k_hi = min(n // 2 - 1, int(math.floor(hi_hz * n / fs)))
    return slice(k_lo, max(k_hi, k_lo + 1) + 1)


def _shift_sum(e: np.ndarray, offsets) -> np.ndarray:
    """``sum_o e[:, k + o]`` over ``offsets`` (zero outside the bins), ``(F, K)``."""
    m = max(abs(o) for o in offsets)
    F, K = e.shape
    pad = np.zeros((F, K + 2 * m))
    pad[:, m:m + K] = e
    return sum(pad[:, m + o:m + o + K] for o in offsets)


def _leave_out_sum(e: np.ndarray, band: slice) -> np.ndarray:
    """Per bin, ``sum e[:, band]`` without the bin and its two neighbours, ``(F, K)``."""
    inband = np.zeros(e.shape[1])
    inband[band] = 1.0
    return e[:, band].sum(axis=1, keepdims=True) - _shift_sum(e * inband, (-1, 0, 1))


def _pending(state: CalibrationState, n_ahead: int):
    """The state's pending frames, padded at the stream start to ``n_ahead`` frozen empty ones."""
    pad = n_ahead - state.pend_x.shape[0]
    if pad <= 0:
        return state.pend_x, state.pend_card
    K = state.pend_x.shape[2]
    return (np.concatenate([np.zeros((pad, 3, K), dtype=complex), state.pend_x]),
            np.concatenate([np.ones((pad, K), dtype=bool), state.pend_card]))


def _frame_weights(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float, n_ahead: int,
                   changes: dict) -> tuple:
    """``(held (F,), kappa (F,) or None, now (F,), talking (F,))``: the frame rule's weights of the frames averaged now (the
    first ``F`` of the ``D`` pending and the block's ``F``), each frame's :func:`_frame_rule` weight held --
    the minimum over the ``level_hang_s`` frames before it and the ``level_ahead_s`` (= ``D``) after it, so
    that a talker's onset and decay around a loud frame are not learned either; ``frame_snr_db``'s share
    of the rule (:func:`_frame_snr_share`); the block's own frames' weights, not held, until the first frame
    the rule weighs below 1 since the stream start (0 from there on); the block's frames where the rule
    hears the talker or its hold after it, at the share's upper half (the DAS weight's mask, no look ahead).
    ``changes`` gets the new state."""
    w, changes["q_frame"], talker, power = _frame_rule(X1, X2, state, p, fs=fs, delay=delay)
    if p.frame_level_db is not None:  # a frame far above the noise floor is not learned either
        loud, changes["q_frame_level"] = _frame_level_rule(X1, X2, state, p, fs=fs)
        w = np.where(loud, 0.0, w)
    n_hang = int(round(float(p.level_hang_s) * fs / int(p.hop)))
    # frame_start_s: the rule's decisions in the stream's first frames, made with a smoother just started and no
    # floor, are not trusted -- the frames are learned as noise, are not held over the frames around them, do
    # not end the start-up and are not the talker's for the SNR share (measured: a real recording's start
    # transient, 3 frames at -3..-8 dB re the noise at 25 dB input, was heard in one of Hagerman's runs only,
    # and that one frame decided the start-up DAS weight of the whole file)
    judged = (state.n_frames + np.arange(len(w))) >= int(round(float(p.frame_start_s) * fs / int(p.hop)))
    w, talker = np.where(judged, w, 1.0), talker & judged
    n_taper = int(round(float(p.frame_hold_taper_s) * fs / int(p.hop)))
    tail = state.w_tail if state.w_tail is not None else np.ones(n_taper + n_hang + n_ahead)  # the start: no hold
    seq = np.concatenate([tail, w])
    changes["w_tail"] = seq[len(w):]
    held = _held(seq, n_hang, n_ahead, n_taper)[:len(w)]
    # the block's frames the rule heard the talker in or in the hold after (no look ahead: for the DAS
    # weight's mask, which cannot wait)
    talking = np.lib.stride_tricks.sliding_window_view(seq[n_taper + n_ahead:], n_hang + 1).min(axis=1)[:len(w)] < 1.0
    # the block's own frames until the talker is first heard (a stream starts on the noise: what the DAS weight
    # may learn at once, mix_fast_cells); nothing after
    quiet = ~np.logical_or.accumulate(w < 1.0) & (not state.heard)
    changes["heard"] = bool(state.heard or (w < 1.0).any())
    now = w * quiet
    if p.frame_snr_db is None:
        return held, None, now, talking
    quiet_frames = quiet_power = None
    if p.frame_snr_quiet:  # the noise's power from the held-quiet frames (D behind), not from every unheard one
        tail_p = state.p_tail if state.p_tail is not None else np.full(n_ahead, np.nan)
        seq_p = np.concatenate([tail_p, power])
        changes["p_tail"] = seq_p[len(w):]
        quiet_power = seq_p[:len(w)]
        quiet_frames = (held >= 1.0) & ~np.isnan(quiet_power)  # NaN: the stream start's placeholders
        if p.frame_snr_quiet_ratio:  # quiet: away from the ratio rule's talker frames (a machine's hit is noise)
            t_tail = state.t_tail if state.t_tail is not None else np.zeros(n_hang + n_ahead, dtype=bool)
            t_seq = np.concatenate([t_tail, talker])
            changes["t_tail"] = t_seq[len(w):]
            near = np.lib.stride_tricks.sliding_window_view(t_seq, n_hang + n_ahead + 1).max(axis=1)[:len(w)]
            quiet_frames = ~near & ~np.isnan(quiet_power)
    kappa, changes["snr"] = _frame_snr_share(talker, power, state.snr, p, fs=fs, quiet=quiet_frames,
                                             quiet_power=quiet_power)
    return held, kappa, now, talking & (kappa >= 0.5)  # at low input SNR the cardioid rules' mask alone


def _held(seq: np.ndarray, n_hang: int, n_ahead: int, n_taper: int) -> np.ndarray:
    """Each frame's held weight: the minimum of ``seq``'s weights from ``n_hang`` frames before it to ``n_ahead``
    after it, where ``seq (R + H + D + F - 1,)`` starts ``R + H`` frames before the first frame (``R = n_taper``).

    ``n_taper = R > 0`` (``frame_hold_taper_s``): the hold's edges taper -- a frame ``R`` more before it and
    the last ``R`` of the ``n_ahead`` after it count with ``c = 1 / (R + 1) ... R / (R + 1)``, rising towards
    the core, as ``1 - c (1 - w)``.  Why: a talker's onset or end heard one frame apart in the runs on ``s +
    n`` and ``s - n`` moved a hard edge over a whole noise frame, learned in one run only; tapered, it moves
    the frame's weight by ``1 / (R + 1)``.

    >>> w = np.array([1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0])
    >>> _held(w, 0, 2, 0).tolist()  # a hard hold: the two frames before the talker's frame
    [1.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    >>> w = np.array([1.0] * 6 + [0.0] + [1.0] * 5)  # tapered by 2: the frames 2..8, the talker at 6
    >>> np.round(_held(w, 0, 3, 2), 3).tolist()  # 1 frame of core ahead, then 2/3 and 1/3; behind 2/3, 1/3
    [1.0, 0.667, 0.333, 0.0, 0.0, 0.333, 0.667]
    """
    if n_taper == 0:
        return np.lib.stride_tricks.sliding_window_view(seq, n_hang + n_ahead + 1).min(axis=1)
    c = np.concatenate([np.arange(1, n_taper + 1) / (n_taper + 1), np.ones(n_hang + 1 + n_ahead - n_taper),
                        np.arange(n_taper, 0, -1) / (n_taper + 1)])  # (the parameter check keeps R <= D)
    win = np.lib.stride_tricks.sliding_window_view(seq, len(c))
    return (1.0 - c * (1.0 - win)).min(axis=1)


#: time constant (s) of the frame rule's input-SNR estimate (frame_snr_db): a few utterances
SNR_TAU_S = 3.0
#: frame_snr_clip_db: the noise frames the average must have before it judges a frame far above it
SNR_CLIP_MIN = 3


def _frame_snr_share(talker, power, snr, p: CalibrationParams, *, fs: int, quiet=None, quiet_power=None):
    """``frame_snr_db = (lo, hi)``: the share ``kappa (F,)`` of the frame rule in the averages' weights, 0 where
    the stream's estimated input SNR is below ``lo`` dB, 1 above ``hi``, linear between; and the new state.

    The estimate: one-pole averages (``SNR_TAU_S``, a running mean at first) of the power over
    ``frame_band_hz`` in the frames the rule marks as the talker's and in the others; their ratio is
    ``(S + N) / N`` of the talker's frames -- the input SNR from ~10 dB up, ~3-5 dB at 0 dB.  Why: the
    speech x noise cross terms that make an estimate learned during speech differ between ``s + n`` and
    ``s - n`` are masked by the noise at low input SNR, while there the cells a talker leaves to the noise are most of a frame and worth most (a single
    plane wave's null: 20-25 dB at 0 dB input).  Until both kinds of frame were seen: the frame rule.

    ``quiet (F,)`` / ``quiet_power (F,)`` (``frame_snr_quiet``): the noise's average runs over these frames and
    powers instead of the frames not marked -- the frames the held rule leaves quiet, ``D`` frames behind.
    Why: a reverberant or quiet talker's frames the ratio misses count as noise otherwise, and pull the
    estimate down towards the low-SNR share (measured on ``phone``'s factory-hall at 15 dB input).

    ``frame_snr_frames = N > 0``: the share moves from 1 (the frame rule) to the estimate's value linearly in
    the count of the rarer kind of frame, reaching it at ``N``: an estimate from a few frames differs between
    ``s + n`` and ``s - n``, and at the stream start it decided which talker frames the low-SNR path learned
    (measured on ``phone``'s babble at 20 dB, built-in data: a frame at 10.5 dB local SNR weighed 0.46 in one
    run, 0.01 in the other).

    ``frame_snr_quiet_ratio`` (with ``frame_snr_quiet``): the quiet frames are those away from the ratio rule's
    talker frames (its hold and look ahead), not the held weights' -- a frame the level rule stops, a machine's
    hit, is noise, and leaving it out made the estimate high in factory noise, where the share then gave up the
    learning during speech that the null of its machine needs (measured on ``phone``'s factory, built-in seed 1:
    2-4 dB of SNR-I at 5-15 dB input).  ``frame_snr_low_hz``: the powers run from there up to ``frame_band_hz``'s
    upper edge (the talker's band; over 1-4 kHz alone a high-frequency noise made 25 dB input read as ~11 dB).
    ``frame_snr_clip_db``: once the noise's average has ``SNR_CLIP_MIN`` frames, a frame that far above it is
    left out of it -- a talker the ratio rule missed is not noise (measured on ``phone``'s hall at 15 dB, built-in
    seed 0: the quiet frames held speech 8.7 dB over the noise on average, and 15 dB input read 4.5 dB)."""
    state = np.zeros(4) if snr is None else snr.copy()
    one_pole = 1.0 - math.exp(-int(p.hop) / (fs * SNR_TAU_S))
    lo, hi = (float(v) for v in p.frame_snr_db)
    n_full = float(p.frame_snr_frames)
    clip = None if p.frame_snr_clip_db is None else 10.0 ** (float(p.frame_snr_clip_db) / 10.0)
    kappa = np.ones(len(power))
    for i in range(len(power)):  # a few scalars per frame
        updates = [(0, power[i])] if talker[i] else []
        if quiet is None:
            updates += [] if talker[i] else [(2, power[i])]
        elif quiet[i]:
            updates.append((2, quiet_power[i]))
        for j, pw in updates:
            if j == 2 and clip is not None and state[3] >= SNR_CLIP_MIN and pw > clip * state[2]:
                continue  # frame_snr_clip_db: far above the noise's average, not noise (a talker the ratio missed)
            state[j + 1] += 1.0
            state[j] += max(1.0 / state[j + 1], one_pole) * (pw - state[j])
        if state[1] > 0 and state[3] > 0:
            snr_db = 10.0 * math.log10((state[0] + TINY) / (state[2] + TINY))
            kappa[i] = min(1.0, max(0.0, (snr_db - lo) / max(hi - lo, TINY)))
            if n_full > 0:  # frame_snr_frames: the estimate's say grows with the frames of the rarer kind
                kappa[i] = 1.0 - (1.0 - kappa[i]) * min(1.0, min(state[1], state[3]) / n_full)
    return kappa, state


def _freeze(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float, band: slice):
    """``(cardioid rules (F, K), state changes)``: True where the averages stop.

    Two cardioid-ratio rules (see the module docstring), neither using the bin's own noise:
    per bin from its neighbours 2 and 3 bins away (outside the Hamming main lobe), and for
    the whole band ``fit_band_hz`` leaving out the bin and its two neighbours.
    """
    ph = np.exp(-1j * bin_omega(int(p.frame_len)) * delay)
    cF, cB = X1 - ph * X2, X2 - ph * X1
    eF, eB = cF.real**2 + cF.imag**2, cB.real**2 + cB.imag**2
    n_window = int(math.ceil(float(p.floor_s) * fs / int(p.hop))) if p.floor_s > 0 else 0
    rule = dict(lam=float(p.gate_lam_cal), n_window=n_window)
    near = (-3, -2, 2, 3)
    per_bin, q = power_ratio_gate(_shift_sum(eF, near), _shift_sum(eB, near), state=state.q_bin,
                                  gate_db=float(p.freeze_db), **rule)
    whole, w = power_ratio_gate(_leave_out_sum(eF, band), _leave_out_sum(eB, band), state=state.q_band,
                                gate_db=float(p.freeze_band_db), **rule)
    return per_bin | whole, {"q_bin": q, "q_band": w}


def _frame_rule(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float):
    """The frame rule: ``(weights (F,), smoother state, talker (F,), power (F,))``, how much each frame may be
    learned from.

    ``q = 10 log10(P_F / P_B)``, the forward/backward cardioid powers summed over ``frame_band_hz``
    (1-4 kHz: 48 bins, where an uncalibrated 1 dB / 5 deg pair still has a backward null ~15 dB deep)
    and one-pole smoothed (``gate_lam_cal``), against the absolute ``frame_q_db``: a diffuse or
    incoherent field gives ~0 dB (+-1 dB over 48 bins), a rear source less, the talker at 45 deg up
    to ~+13 dB.  Level-free (babble's and a machine's level swings do not move it) and one decision
    for the whole frame: the talker is broadband, and where it is absent ``s + n`` and ``s - n`` are
    the same up to sign in every bin.  The weight is 1 below ``frame_q_db``, 0 from it up.  Also
    returned: where the rule hears the talker ``(F,)`` and the front mic's band power ``(F,)`` (over
    ``frame_band_hz``, or from ``frame_snr_low_hz`` up to its upper edge) for the SNR share.
    """
    bands = [_band(p, fs, p.frame_band_hz)]
    if p.frame_low_hz is not None:  # the band below, judged on its own (a voiced syllable's energy lies there)
        bands.append(_band(p, fs, (float(p.frame_low_hz), float(p.frame_band_hz[0]))))
    lo, hi = min(k.start for k in bands), max(k.stop for k in bands)  # the cardioids of these bins only
    ph = np.exp(-1j * bin_omega(int(p.frame_len))[lo:hi] * delay)
    a, b = X1[:, lo:hi], X2[:, lo:hi]
    cF, cB = a - ph * b, b - ph * a
    eF, eB = cF.real**2 + cF.imag**2, cB.real**2 + cB.imag**2
    pf = np.stack([eF[:, k.start - lo:k.stop - lo].sum(axis=1) for k in bands], axis=1)  # (F, bands)
    pb = np.stack([eB[:, k.start - lo:k.stop - lo].sum(axis=1) for k in bands], axis=1)
    gate = state.q_frame if state.q_frame is not None else gate_init(len(bands))
    sf = smooth_frames(pf, float(p.gate_lam_cal), gate.pf)
    sb = smooth_frames(pb, float(p.gate_lam_cal), gate.pb)
    q = 10.0 * np.log10((sf + TINY) / (sb + TINY)).max(axis=1)  # the talker's if any band says so
    top = float(p.frame_q_db)
    w = (q < top).astype(float)
    new = GateState(pf=sf[-1].copy(), pb=sb[-1].copy(), sf=gate.sf, sb=gate.sb) if len(q) else gate
    # the front mic's power for the SNR share: over frame_band_hz, or from frame_snr_low_hz up to its upper edge
    a = X1[:, bands[0] if p.frame_snr_low_hz is None else _band(p, fs, (float(p.frame_snr_low_hz), p.frame_band_hz[1]))]
    return w, new, q >= top, (a.real**2 + a.imag**2).sum(axis=1)


def _frame_level_rule(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int):
    """``frame_level_db``: ``(loud (F,), gate state)``, True where the frame's power over the frame rule's bands
    (both mics, ``frame_low_hz`` or ``frame_band_hz``'s lower edge up to its upper edge), one-pole smoothed
    (``gate_lam_cal``), is more than ``frame_level_db`` above its running minimum over ``level_floor_s``
    (minimum statistics: the noise floor).

    Why a level as well as the ratio: the phone's uncalibrated pair hardly tells the talker from a diffuse
    field below 1 kHz (its ratio there is ~0-5 dB, measured on the ``phone`` preset), and a voiced syllable
    can carry its power there: 25 dB above wind in 250 Hz-1 kHz while 2-3 dB in 1-4 kHz, where the ratio
    never reaches the threshold.  A level rule cannot tell the talker from a swing of the noise, but a
    false alarm only costs frames learned; the ratio still covers a talker at the noise's level.
    The filter bank's first frames hold part of a window of signal, too quiet for a floor: they stay out of
    it and are left to the ratio (counted loud, they would end the start-up weights' learning at once)."""
    lo = float(p.frame_low_hz) if p.frame_low_hz is not None else float(p.frame_band_hz[0])
    k = _band(p, fs, (lo, float(p.frame_band_hz[1])))
    e = (X1[:, k].real**2 + X1[:, k].imag**2 + X2[:, k].real**2 + X2[:, k].imag**2).sum(axis=1, keepdims=True)
    F = e.shape[0]
    n_start = -(-int(p.frame_len) // int(p.hop)) - 1
    m = min(F, max(0, n_start - state.n_frames))
    gate = state.q_frame_level if state.q_frame_level is not None else gate_init(1)
    if m == F:
        return np.zeros(F, dtype=bool), gate
    if state.n_frames + m <= n_start:  # the smoother starts at the first full frame's level, not at 0
        gate = dataclasses.replace(gate, pf=e[m].copy())
    n_window = max(1, int(math.ceil(float(p.level_floor_s) * fs / int(p.hop))))
    loud, gate = power_ratio_gate(e[m:], np.ones_like(e[m:]), state=gate, gate_db=float(p.frame_level_db),
                                  lam=float(p.gate_lam_cal), n_window=n_window, cap=math.inf)
    return np.concatenate([np.zeros(m, dtype=bool), loud[:, 0]]), gate


def _propagation_slope(s21: np.ndarray, band: slice, max_slope: float) -> np.ndarray:
    """Propagation phase slope (rad per bin) of ``s21 (F, K)`` over ``band``, ``(F,)``.

    A first guess from the lag-one product across bins, ``b0 = angle(sum S21[k+1] conj(S21[k]))``;
    then the residual phase ``psi_k = angle(S21[k] e^{-j b0 k})`` (small: no unwrapping) is fitted
    by weighted least squares (weights ``|S21|``) with ``a + b1 k + c / k``: the ``c / k`` term
    takes up the phase of unequal high-pass corners (``atan(fc1/f) - atan(fc2/f) ~ (fc1 - fc2)/f``),
    which would otherwise bias the slope.  Returns ``clip(b0 + b1, -max_slope, max_slope)``.
    """
    k = np.arange(band.start, band.stop, dtype=float)
    seg = s21[:, band]
    b0 = np.angle(np.sum(seg[:, 1:] * np.conj(seg[:, :-1]), axis=1))  # angle(0) = 0 on silence
    psi = np.angle(seg * np.exp(-1j * b0[:, None] * k[None, :]))
    w = np.abs(seg)
    w = w / (np.max(w, axis=1, keepdims=True) + TINY)
    A = np.stack([np.ones_like(k), k / k[-1], k[0] / k])  # scaled columns: a well-conditioned 3x3
    M = np.einsum("fk,ik,jk->fij", w, A, A) + 1e-9 * np.eye(3)
    rhs = np.einsum("fk,ik,fk->fi", w, A, psi)
    coef = np.linalg.solve(M, rhs[..., None])[..., 0]
    return np.clip(b0 + coef[:, 1] / k[-1], -max_slope, max_slope)


def _smooth_bins(x: np.ndarray, half_width: np.ndarray) -> np.ndarray:
    """Mean of ``x (F, K)`` over bins ``k - m_k .. k + m_k`` (cut at the edges), ``m = half_width (K,)``."""
    K = x.shape[1]
    cs = np.concatenate([np.zeros((x.shape[0], 1), dtype=x.dtype), np.cumsum(x, axis=1)], axis=1)
    k = np.arange(K)
    lo = np.maximum(k - half_width, 0)
    hi = np.minimum(k + half_width + 1, K)
    return (cs[:, hi] - cs[:, lo]) / (hi - lo)


def estimate_from_averages(avg: np.ndarray, *, band: slice, max_slope: float, smooth_bins: int,
                           smooth_frac: float, max_gain_db: float, max_phase_deg: float,
                           min_coherence: float = 0.0, prev_phase: np.ndarray | None = None,
                           phase_leak: float = 1.0) -> np.ndarray:
    """``r_hat (F, K)`` from averages ``avg (F, 3, K)`` = (S11, S22, S21) (see module docstring).

    Where the band-averaged coherence ``|S21| / sqrt(S11 S22)`` is below ``min_coherence`` the phase
    of the previous estimate (``prev_phase (K,)``, else of the last row that had it) is kept, times ``phase_leak`` per update since that row (a pull towards 0:
    a phase seen by chance in incoherent noise fades instead of staying).
    """
    s11, s22, s21 = avg[:, 0].real, avg[:, 1].real, avg[:, 2]
    slope = _propagation_slope(s21, band, max_slope)
    k = np.arange(s21.shape[1])
    derot = s21 * np.exp(-1j * slope[:, None] * k[None, :])
    half = np.maximum(int(smooth_bins), np.round(smooth_frac * k).astype(int))
    derot, s11, s22 = _smooth_bins(derot, half), _smooth_bins(s11, half), _smooth_bins(s22, half)
    gain_db = np.clip(10.0 * np.log10((s22 + TINY) / (s11 + TINY)), -max_gain_db, max_gain_db)
    phase = np.clip(np.angle(derot), -math.radians(max_phase_deg), math.radians(max_phase_deg))
    if min_coherence > 0 and phase.shape[0]:
        valid = np.abs(derot) >= min_coherence * np.sqrt(s11 * s22)
        rows = np.maximum.accumulate(np.where(valid, np.arange(phase.shape[0])[:, None], -1), axis=0)
        held = phase[np.maximum(rows, 0), np.arange(phase.shape[1])[None, :]]
        prev = np.zeros(phase.shape[1]) if prev_phase is None else prev_phase
        u = np.arange(phase.shape[0])[:, None]
        phase = np.where(rows >= 0, held * phase_leak ** (u - rows), prev[None, :] * phase_leak ** (u + 1))
    return 10.0 ** (gain_db / 20.0) * np.exp(1j * phase)


def model_estimate(avg: np.ndarray, counts: np.ndarray, theta: np.ndarray | None, p: CalibrationParams, *,
                   fs: int, band: slice, max_slope: float):
    """``model="hp1"``: ``(r_hat (U, K), last theta (4,))`` from averages ``avg (U, 3, K)`` = (S11, S22, S21) of
    ``U`` update frames and their per-bin active frame counts ``counts (U, K)``.

    Per bin the measured ``ln r = 0.5 ln(S22 / S11) + j angle(S21 e^{-j b k})`` (``b``: the propagation
    slope of :func:`_propagation_slope`, whose ``c / k`` term leaves the corners' phase in), fitted over
    ``model_band_hz`` by :func:`enhancers.beam.calibration_model.fit_hp1` (with a nuisance phase slope within
    twice the physical range ``max_slope`` rad per bin, which ``r`` leaves out), each update warm-started from the
    previous fit (``theta``; None: the prior), ``model_iter`` steps.  Weights: inverse variances for
    jointly Gaussian spectra with coherence ``gamma`` (capped at 0.99) over ``n`` frames (the bin's
    active frames, at most the one-pole's ``2 tau_s fs / hop``; ``gamma^2`` from the averages, its ``1 / n``
    bias removed): log gain ``2 n / (1 - gamma^2)``, phase
    ``2 n gamma^2 / (1 - gamma^2)``, 0 where ``gamma < min_coherence`` (no phase to measure); both 0 where
    the measurement is beyond ``max_gain_db`` / ``max_phase_deg`` (outside the model's range).  The model's
    ``r`` is used in every bin, clipped like the per-bin estimate.

    >>> import numpy as np, enhancers
    >>> p = enhancers.make("mic-calibration", model="hp1").params
    >>> avg = np.ones((1, 3, 129), dtype=complex)  # equal powers, coherent, no phase: r = 1
    >>> r, th = model_estimate(avg, np.full((1, 129), 500.0), None, p, fs=16000, band=_band(p, 16000), max_slope=0.1)
    >>> bool(np.allclose(r, 1.0, atol=1e-6)), r.shape
    (True, (1, 129))
    """
    s11, s22, s21 = avg[:, 0].real, avg[:, 1].real, avg[:, 2]
    k = np.arange(s21.shape[1])
    slope = _propagation_slope(s21, band, max_slope)
    log_r = 0.5 * np.log((s22 + TINY) / (s11 + TINY)) + 1j * np.angle(s21 * np.exp(-1j * slope[:, None] * k))
    n = np.minimum(counts, 2.0 * float(p.tau_s) * fs / int(p.hop))
    # the coherence of n frames is biased up by ~(1 - gamma^2) / n (one frame's is always 1): unbiased, capped
    coh2 = (s21.real**2 + s21.imag**2) / (s11 * s22 + TINY)
    coh2 = np.clip((n * coh2 - 1.0) / np.maximum(n - 1.0, 1.0), 0.0, 0.99)
    # a bin whose measurement the clip would cut says nothing the sensor model can explain (e.g. wind's
    # convected phase, an unequal burst): left out, as the per-bin estimate clips it
    g_max, ph_max = float(p.max_gain_db) * math.log(10.0) / 20.0, math.radians(float(p.max_phase_deg))
    w_gain = np.where(np.abs(log_r.real) <= g_max, 2.0 * n / (1.0 - coh2), 0.0)
    w_phase = np.where((coh2 >= float(p.min_coherence) ** 2) & (np.abs(log_r.imag) <= ph_max), w_gain * coh2, 0.0)
    f_hz, fit = k * fs / int(p.frame_len), _band(p, fs, p.model_band_hz)
    # what the removed slope may have left: up to twice the physical range (it was clipped to it), rad per kHz
    slope_khz = 2.0 * max_slope * int(p.frame_len) / fs * 1000.0
    out = np.empty(s21.shape, dtype=complex)
    for u in range(s21.shape[0]):  # each fit starts from the previous one
        theta = fit_hp1(f_hz[fit], log_r[u, fit], w_gain[u, fit], w_phase[u, fit], theta, n_iter=int(p.model_iter),
                        max_slope=slope_khz, prior_scale=float(p.model_prior),
                        robust=None if p.model_robust is None else float(p.model_robust))
        lr = hp1_log_response(f_hz, theta)
        out[u] = np.exp(np.clip(lr.real, -g_max, g_max) + 1j * np.clip(lr.imag, -ph_max, ph_max))
    return out, theta


def calibration_step(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float):
    """Estimate ``r_hat`` for the frames of one block.

    Returns ``(r_hat (F, K), frozen (F, K), state)``, ``frozen`` the mask the DAS weight uses
    (:func:`calibration_masks_step`'s cardioid mask or-ed with its talker mask).
    """
    r_hat, card, talker, state = calibration_masks_step(X1, X2, state, p, fs=fs, delay=delay)
    return r_hat, card | talker, state


def calibration_masks_step(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float,
                           learn_out: list | None = None):
    """Estimate ``r_hat`` for the frames of one block, with the causal masks of the two kinds of rule.

    Parameters
    ----------
    X1, X2 : complex (F, K)
        Front and rear spectra.
    state : CalibrationState
    p : CalibrationParams
    fs : int
    delay : float
        ``T fs`` (samples).

    Returns
    -------
    r_hat : complex (F, K); cardioid : bool (F, K), the cardioid rules' decisions (all False with the frame
    rule); talker : bool (F, K), the block's frames where the frame rule hears the talker or holds after it,
    at an SNR share of at least 0.5 (no look ahead: what the DAS weight, which cannot wait, uses; all False
    without the frame rule); new state.  With ``learn_out`` (a list), a pair is appended to it: the weights
    ``(F, K)`` in ``[0, 1]`` with which the averages learned the frames they reached in this block
    (``level_ahead_s`` behind the block's), and the rules' weights of the block's own frames without hold or
    look ahead (the frame rule's until it first hears the talker, or where the cardioid rules did not freeze
    them): ``mix_model="delayed"`` learns the DAS weight on the first, and on the second while the first has
    few cells (``mix_fast_cells``).
    """
    if p.cal_rear_db is None or X1.shape[0] == 0:
        return _masks_step(X1, X2, state, p, fs=fs, delay=delay, learn_out=learn_out)
    # the rear rule needs the estimate so far: chunks of cal_chunk frames counted from the stream start (so
    # blocks of any size give the same chunks), each judged with the estimate applied at its start (state.r_dir)
    F, n = X1.shape[0], int(p.cal_chunk)
    parts, lo = [], 0
    while lo < F:
        if state.n_frames % n == 0:
            state = dataclasses.replace(state, r_dir=state.r_last.copy())
        hi = min(F, lo + n - state.n_frames % n)
        rear, changes = _rear_rule(X1[lo:hi], X2[lo:hi], state, p, delay=delay)
        state = dataclasses.replace(state, **changes)
        r, card, talker, state = _masks_step(X1[lo:hi], X2[lo:hi], state, p, fs=fs, delay=delay, rear=rear,
                                             learn_out=learn_out)
        parts.append((r, card, talker))
        lo = hi
    return (*(np.concatenate([q[i] for q in parts]) for i in range(3)), state)


def _rear_rule(X1, X2, state: CalibrationState, p: CalibrationParams, *, delay: float):
    """The rear rule: ``(rear (F, K), state changes)`` -- where the cell is dominated from behind, ``P_B / P_F``
    above ``cal_rear_db`` (a talker in front at ``rho`` below such a rear source raises the ratio by ~``rho``
    plus its cardioid contrast, so a strict threshold certifies that the talker is far below the noise there).

    The forward/backward cardioids of the *calibrated* pair ``X1, X2 / r`` (``r``: the estimate applied at the
    start of the chunk of ``cal_chunk`` frames, ``state.r_dir``; uncalibrated, a 1 dB / 5 deg mismatch pulls
    every source's ratio towards 0 dB at low frequencies), powers over the bins :data:`LEVEL_NEAR` away,
    one-pole smoothed (``gate_lam_cal``).  ``rear``: with ``cal_rear_soft_db > 0`` the smoothed ratio in dB
    (smoother ``cal_rear_lam``, graded by :func:`_rear_weight`); else bool over ``cal_rear_db``, or with
    ``cal_rear_low_db`` uint8 levels (2: over ``cal_rear_db``, 1: over ``cal_rear_low_db`` only).
    """
    ph = np.exp(-1j * bin_omega(int(p.frame_len)) * delay)
    X2c = X2 / state.r_dir[None, :]
    cF, cB = X1 - ph * X2c, X2c - ph * X1
    eF, eB = cF.real**2 + cF.imag**2, cB.real**2 + cB.imag**2
    pF, pB = _shift_sum(eF, LEVEL_NEAR), _shift_sum(eB, LEVEL_NEAR)
    rule = dict(lam=float(p.gate_lam_cal), n_window=0)
    changes = {}
    q = state.q_rear if state.q_rear is not None else gate_init(pF.shape[1])
    if p.cal_rear_soft_db > 0:  # graded: the smoothed ratio itself (dB), as the gate
        # cal_rear_lam: a slower smoother averages the talker x noise cross term in P_F over more frames
        lam = rule["lam"] if p.cal_rear_lam is None else float(p.cal_rear_lam)
        # the state's pf holds P_B and pb holds P_F, as power_ratio_gate(pB, pF) of the hard rule stores them
        sb, sf = smooth_frames(pB, lam, q.pf), smooth_frames(pF, lam, q.pb)
        rear = 10.0 * np.log10((sb + TINY) / (sf + TINY))
        changes["q_rear"] = GateState(pf=sb[-1].copy(), pb=sf[-1].copy()) if len(rear) else q
        return rear, changes
    rear, changes["q_rear"] = power_ratio_gate(pB, pF, state=q, gate_db=float(p.cal_rear_db), **rule)
    if p.cal_rear_low_db is not None:  # 2: over cal_rear_db, 1: over cal_rear_low_db only (same smoothing)
        low, _ = power_ratio_gate(pB, pF, state=q, gate_db=float(p.cal_rear_low_db), **rule)
        rear = rear.astype(np.uint8) + low
    return rear, changes


def _rear_weight(ratio_db: np.ndarray, kappa, p: CalibrationParams) -> np.ndarray:
    """``cal_rear_soft_db = g > 0``: the rear rule's weight of each cell ``(F, K)`` from its smoothed ``P_B / P_F``
    (dB): a ramp from 0 at ``cal_rear_db`` to 1 at ``cal_rear_db + g``; with ``cal_rear_low_db`` the larger of
    that and ``1 - kappa (F,)`` (the SNR share) where the ratio is over the low threshold (hard: the share
    grades it).  Why graded: ``P_F`` holds the talker, and near a hard threshold the talker x noise cross
    term in it decided whether a cell was learned -- in one of Hagerman's runs only (measured on ``phone``'s
    factory at 20-25 dB, ``../shared/data``: weights 0.6-0.7 in one run, 0.1 in the other, at -13..-25 dB
    local SNR).  The ramp starts at the threshold, not below it: a lower ratio lets more of the talker in
    (centred on the threshold, the worst of those rows was -29.5 dB with g = 4 and -22.6 dB with g = 8).

    >>> import enhancers
    >>> p = enhancers.make("mic-calibration", frame_q_db=5.0, frame_snr_db=(8.0, 14.0), cal_rear_db=10.0,
    ...                    cal_rear_low_db=6.0, cal_rear_soft_db=4.0).params
    >>> _rear_weight(np.array([[5.0, 7.0, 10.0, 11.0, 13.0, 15.0]]), np.array([0.75]), p).tolist()
    [[0.0, 0.25, 0.25, 0.25, 0.75, 1.0]]
    """
    w = np.clip((ratio_db - float(p.cal_rear_db)) / float(p.cal_rear_soft_db), 0.0, 1.0)
    if p.cal_rear_low_db is None or kappa is None:
        return w
    return np.maximum(w, (ratio_db > float(p.cal_rear_low_db)) * (1.0 - kappa[:, None]))


def _masks_step(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float, rear=None,
                learn_out: list | None = None):
    """:func:`calibration_masks_step` for one chunk; ``rear (F, K)``: the rear rule's decisions
    (:func:`_rear_rule`; cells the averages learn from whatever the other rules say) or None."""
    F, K = X1.shape
    if F == 0:
        none = np.zeros((0, K), dtype=bool)
        if learn_out is not None:
            learn_out.append((np.zeros((0, K)), np.zeros((0, K))))
        return np.ones((0, K), dtype=complex), none, none, state
    band = _band(p, fs)
    card, changes = _freeze(X1, X2, state, p, fs=fs, delay=delay, band=band)
    card_learn = card
    if p.frame_q_db is not None and p.frame_snr_db is None:  # the frame rule replaces the cardioid rules (with
        card_learn = np.zeros_like(card_learn)  # frame_snr_db they stay, for low SNR); the start's placeholders stay frozen
    x = np.stack([X1.real**2 + X1.imag**2, X2.real**2 + X2.imag**2, X2 * np.conj(X1)], axis=1)
    # the averages run level_ahead_s (D frames) behind the input, so the frame rule can freeze
    # a frame for what comes after it too (a talker's onset rises over several frames)
    n_ahead = p.look_ahead_frames(fs)
    pend_x, pend_card = _pending(state, n_ahead)
    xs, cards = np.concatenate([pend_x, x]), np.concatenate([pend_card, card_learn])
    learn_frozen = cards[:F]
    talker = np.zeros((F, K), dtype=bool)
    frame_w = kappa = None
    if p.frame_q_db is not None:  # the frame rule's held weights; the DAS weight's mask gets its talker frames
        frame_w, kappa, frame_now, talking = _frame_weights(X1, X2, state, p, fs=fs, delay=delay, n_ahead=n_ahead,
                                                            changes=changes)
        card = np.zeros_like(card)
        talker = talker | talking[:, None]
    rear_now = None
    if rear is not None:  # judged on the block's frames, which the averages reach n_ahead frames later
        pend_rear = (state.pend_rear if state.pend_rear is not None
                     else np.zeros((n_ahead, rear.shape[1]), dtype=rear.dtype))
        rears = np.concatenate([pend_rear, rear])
        rear_now = rears[:F]
        if p.cal_rear_soft_db > 0:  # graded: the ratio in dB; over the lowest threshold, as a level >= 1 below
            over = rear_now > float(p.cal_rear_db if p.cal_rear_low_db is None else p.cal_rear_low_db)
        else:
            over = rear_now > 0
        learn_frozen = learn_frozen & ~over
        changes["pend_rear"] = rears[F:]
    changes.update(pend_x=xs[F:], pend_card=cards[F:])
    # per-bin step: 1/n for the n-th active frame (a running mean) until it reaches the one-pole's
    # 1 - lam, then 1 - lam; 0 where frozen
    active = ~learn_frozen
    one_pole = 1.0 - math.exp(-int(p.hop) / (fs * float(p.tau_s)))
    if frame_w is None:
        counts = state.counts + np.cumsum(active, axis=0)
        c = np.where(active, np.maximum(1.0 / np.maximum(counts, 1), one_pole), 0.0)
        if learn_out is not None:
            learn_out.append((active.astype(float), (~(card | talker)).astype(float)))
    else:  # weighted: the running mean of the weights' sum until it reaches the one-pole, times the weight
        if kappa is None:
            wt = active * frame_w[:, None]
        else:  # frame_snr_db: from the cardioid rules' cells at low input SNR to the frame rule's at high
            real = (state.n_frames + np.arange(F)) >= n_ahead  # not the stream start's placeholders
            wt = kappa[:, None] * (real * frame_w)[:, None] + (1.0 - kappa[:, None]) * active
        if rear_now is not None and p.cal_rear_soft_db > 0:  # graded: 0 at a threshold, 1 cal_rear_soft_db over it
            wt = np.maximum(wt, _rear_weight(rear_now, kappa, p))
        elif rear_now is not None and p.cal_rear_low_db is not None:  # the low threshold counts as the share
            wt = np.maximum(wt, np.where(rear_now >= 2, 1.0, (rear_now == 1) * (1.0 - kappa[:, None])))  # falls
        elif rear_now is not None:  # a rear-dominated cell is learned in a talker's frame too
            wt = np.maximum(wt, rear_now)
        if learn_out is not None:
            learn_out.append((wt, np.broadcast_to(frame_now[:, None], wt.shape).copy()))
        counts = state.counts + np.cumsum(wt, axis=0)
        c = np.where(wt > 0, wt * np.maximum(1.0 / np.maximum(counts, TINY), one_pole), 0.0)
    every = int(p.estimate_every)
    is_update = (state.n_frames + np.arange(F)) % every == 0
    avg = np.empty((int(is_update.sum()), 3, K), dtype=complex)
    a = state.avg.copy()
    j = 0
    for i in range(F):  # a time-varying one-pole per bin: loop over frames, vectorised over bins
        a += c[i] * (xs[i] - a)
        if is_update[i]:
            avg[j] = a
            j += 1
    r_raw, r_upd = _estimate_updates(avg, counts[is_update], state, p, fs=fs, band=band, delay=delay, changes=changes)
    raw_last = r_raw[-1].copy() if r_raw.shape[0] else state.raw_last
    # every frame uses the estimate of the last update frame (the previous block's when none yet)
    held = np.concatenate([state.r_last[None], r_upd], axis=0)
    r_hat = held[np.cumsum(is_update)]
    values = dict(vars(state))
    values.update(avg=a, r_last=held[-1].copy(), raw_last=raw_last, n_frames=state.n_frames + F, counts=counts[-1].copy(), **changes)
    return r_hat, card, talker, CalibrationState(**values)


def _estimate_updates(avg, n_upd, state: CalibrationState, p: CalibrationParams, *, fs: int, band: slice,
                      delay: float, changes: dict):
    """``(raw, applied)`` estimates ``(U, K)`` of the ``U`` update frames from their averages ``avg (U, 3, K)``
    and active frame counts ``n_upd (U, K)``: per bin or by the model (``model``; its last fit goes into
    ``changes["theta"]``), then the start-up ramp ``r^min(1, n / ramp_frames)``."""
    max_slope = 2 * math.pi * delay / int(p.frame_len)
    if p.model == "hp1":
        r_raw, changes["theta"] = model_estimate(avg, n_upd, state.theta, p, fs=fs, band=band, max_slope=max_slope)
        # the fit pools every cell of model_band_hz: the ramp counts them all, the same for every bin
        n_upd = np.broadcast_to(n_upd[:, _band(p, fs, p.model_band_hz)].sum(axis=1, keepdims=True), n_upd.shape)
    else:
        r_raw = estimate_from_averages(avg, band=band, max_slope=max_slope,
                                       smooth_bins=int(p.smooth_bins), smooth_frac=float(p.smooth_frac),
                                       max_gain_db=float(p.max_gain_db), max_phase_deg=float(p.max_phase_deg),
                                       min_coherence=float(p.min_coherence), prev_phase=np.angle(state.raw_last),
                                       phase_leak=float(p.phase_leak))
    # shrunk towards the nominal 1 while a bin has few active frames n: r^min(1, n / ramp_frames)
    # (a few frames' estimate is noisy, and whatever of the talker leaks into them weighs 1/n)
    r_upd = np.exp(np.minimum(1.0, n_upd / float(p.ramp_frames)) * np.log(r_raw)) if p.ramp_frames > 0 else r_raw
    return r_raw, r_upd


def calibration_trace(record: dict) -> dict:
    r = record["r_hat"]
    return {"rear_gain_db": 20.0 * np.log10(np.abs(r)), "rear_phase_deg": np.degrees(np.angle(r)),
            "frozen": record["frozen"].astype(float)}


class MicCalibration(fast_frames.FusedStreaming, StftEnhancer):
    """Rear-mic self-calibration: outputs ``[front, rear / r_hat]`` (see module docstring).

    Parameters (``MicCalibration.Params``)
    --------------------------------------
    spacing_m, c_mps : pair spacing (m), speed of sound (m/s).
    frame_len, hop, window : WOLA filter bank (default 256 / 128 / Hamming).
    tau_s : time constant of the averages over active frames (default 1 s).
    fit_band_hz : band of the propagation-slope estimate and of the freeze rule (default 500-4000 Hz).
    smooth_bins : the estimate is averaged over ``2 smooth_bins + 1`` bins (default 1).
    max_gain_db, max_phase_deg : clip of the estimate (default 6 dB, 30 deg).
    min_coherence, phase_leak : below that coherence the phase is held, fading by ``phase_leak``
        per update (default 0.3, 0.98).
    smooth_frac : the averaging band widens to ``+-smooth_frac k`` bins (default 0.06).
    estimate_every : frames between recomputations of ``r_hat`` (default 4).
    freeze_db, freeze_band_db : freeze thresholds of the per-bin and band rules (default 2 and 1 dB above
        the 1-s floor).
    gate_lam_cal, floor_s : smoothing of the freeze ratios per frame (0.7) and the floor's window (1 s).
    frame_q_db, frame_band_hz, frame_low_hz, frame_level_db, level_floor_s, frame_start_s : the frame rule
        (module docstring; None: off / 1-4 kHz / None / None / 3 s / 0 s).
    level_hang_s, level_ahead_s, frame_hold_taper_s : its hold after and before a talker frame and the
        hold's taper (0.1 s / 0.1 s / 0 s).
    frame_snr_db, frame_snr_frames, frame_snr_low_hz, frame_snr_quiet, frame_snr_quiet_ratio,
    frame_snr_clip_db : the SNR share (:func:`_frame_snr_share`; None: off / 0 / None / False / False / None).
    cal_rear_db, cal_rear_low_db, cal_rear_soft_db, cal_rear_lam, cal_chunk : the rear rule
        (:func:`_rear_rule`; None: off / None / 0 dB / None / 8 frames).
    ramp_frames : the start-up ramp's length in active frames (0: none).
    model, model_band_hz, model_iter, model_prior, model_robust : what ``r_hat`` is (``"bins"``: per-bin
        averages; ``"hp1"``: the 4-parameter sensor model fitted over 100-4000 Hz, 3 Gauss-Newton steps per
        update, prior scale 1000, Cauchy weights with a 0.05 floor (None: plain least squares); module docstring).

    Examples
    --------
    >>> import numpy as np, enhancers
    >>> y = enhancers.make("mic-calibration").process(np.random.default_rng(0).standard_normal((2, 8000)), 16000)
    >>> y.output.shape
    (2, 8000)
    """

    name: ClassVar[str] = "mic-calibration"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "rear-mic self-calibration per STFT bin from far-field/diffuse noise (2 ch out)"
    channels_out: ClassVar[int] = 2

    @dataclass(frozen=True)
    class Params(CalibrationParams):
        def __post_init__(self):
            self._check_calibration()

    def _algo_init(self, fs, n_bins):
        if fast_frames.COMPILED and fast_frames.kernel_supports(self.params):  # the compiled step
            return fast_frames.new_state(self.params, fs, n_bins, delay=self.delay_samples(fs),
                                         filterbank=self.filterbank, band=_band(self.params, fs), beam=False)
        return calibration_init(n_bins)

    def _frames(self, X, algo, fs):
        if isinstance(algo, fast_frames.FastState):  # the compiled step (enhancers.kernels.frames)
            Y, record = algo.frames(X)
            return Y, algo, record
        r_hat, frozen, algo = calibration_step(X[0], X[1], algo, self.params, fs=fs, delay=self.delay_samples(fs))
        return np.stack([X[0], X[1] / r_hat]), algo, {"r_hat": r_hat, "frozen": frozen}

    def _apply(self, record, X, fs):
        return np.stack([X[0], X[1] / record["r_hat"]])

    def _trace(self, record):
        return calibration_trace(record)
