"""Robust differential beamformer: calibration + sub-band EB + noise-aware EQ (``"eb-robust"``, ``"eb-robust-ss"``).

One WOLA filter bank carries every step per frame (so the latency is one frame,
``frame_len - 1`` samples, not one per stage):

1. :func:`enhancers.beam.mic_calibration.calibration_step` estimates the rear mic's complex
   response ``r_hat`` per bin (slow, frozen while a frontal talker dominates) and the rear
   spectrum is divided by it; the DAS weight learns only where the calibration's masks leave a cell
   open (with the frame rule, ``eb-robust-blind``: where the talker is absent);
2. :func:`enhancers.beam.subband_eb.subband_beta_step` adapts one real beta per bin on the
   calibrated spectra (gate on by default: 3 dB above the 1-s floor, as ``eb-gated``);
3. :func:`enhancers.core.eq.look_eq_gain` equalises the look direction with the white-noise-gain
   bound ``eq_noise_gain_db`` (default 9 dB: sensor self-noise leaves the output at most
   9 dB above one mic's self-noise PSD in any bin), an 80 Hz high-pass, and the 90-degree
   phase correction (``eq_phase``: the output is the look-direction speech, not its shifted
   version);
4. the DAS fallback (``das_mix``, see :mod:`enhancers.beam.subband_eb`): per bin, the output
   moves towards a delay-and-sum with the same look response where that has less noise --
   where the noise is incoherent between the mics (wind, self-noise), which no differential
   pattern can reduce.  Its weight learns only in bins the calibration does not freeze,
   starts from ``mix_alpha0 = 0.5`` (the minimax prior: the output-noise excess is
   quadratic, ``(alpha - alpha*)^2 S_DD``, for an unknown ``alpha*`` in ``[0, 1]``), is
   regularised relative to the noise-only front-mic power (so a loud talker does not move
   it) and is fitted over ``2 mix_smooth_bins + 1 = 17`` neighbouring bins (~1 kHz).
   Measured (``phone`` preset, wind, 5 seeds x 6 SNRs; PESQ = raw P.862 of the output):
   ``eb-robust-ss`` 2.54 against an oracle ``alpha = 1`` 2.56 and plain ``ss`` 2.50.  A regulariser relative to the
   current frame's power instead would pull the weight to its prior with every syllable, and
   noise that switches path with the speech is what ``ss``'s minimum statistics cannot follow.

Processing the calibrated pair with ``eb-subband`` as a separate stage would give the
same operation up to one more frame of delay (a WOLA round trip between the stages).

Measured (``python -m benchmarks.studies.robust_eb``: speech from 45 deg far field, babble from
one far-field source at 135 / 240 deg or diffuse, or Corcos wind, 5 dB SNR, 20 s scored after
8 s, mean of 3 seeds): SNR-I 27.8 / 26.6 / 3.4 / 8.6 dB with ideal mics and 27.5 / 26.2 /
3.3 / 7.9 dB with the rear mic 1 dB / 5 deg off (plain ``eb``: 6.6 / 8.4 / 2.8 / -26.0 ->
-0.7 / -0.5 / -0.8 / -26.8 dB; ``eb-gated``: 29.8 / 26.6 / 3.8 -> 1.5 / 1.5 / 0.6 dB).
Broadband amplification of spatially white noise re the look direction -0.2 dB (fixed
cardioid 10.3 dB).  Convergence: the calibration starts as a running mean and then has a
1 s time constant of *active* (unfrozen) time; scored over the whole signal (the
``mismatch`` preset restricted to 0 / 1 dB x 0 / 5 deg, 10 s, babble at 5 dB) the loss
from 1 dB / 5 deg stays within 1.3 dB (worst: 240 deg without self-noise; 2.0 dB there
before the DAS mix weight was made noise-referenced and bin-averaged).

``trace``: ``"beta"`` and ``"alpha"`` (``(n_frames, n_bins)``) plus the calibration trace of
:class:`enhancers.beam.mic_calibration.MicCalibration`.  ``eb-robust-ss`` is ``eb-robust``
followed by ``ss`` (a :class:`enhancers.core.chain.Chain`, prefixes ``eb`` and ``ss``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.beam.mic_calibration import (
    CalibrationParams,
    _band,
    calibration_init,
    calibration_masks_step,
    calibration_trace,
)
from enhancers.beam.presets import EB_ROBUST_BLIND, EB_ROBUST_BLIND_SS
from enhancers.beam.subband_eb import SubbandBase, SubbandEbParams, subband_init
from enhancers.core.base import params_with_defaults
from enhancers.core.chain import Chain
from enhancers.kernels import frames as fast_frames
from scenesim.errors import ParameterError

__all__ = ["EbRobustBlindSs", "EbRobustSs", "RobustElkoBeamformer", "TalkerBlindRobustEb"]


class RobustElkoBeamformer(SubbandBase):
    """Calibrated sub-band Elko beamformer with a noise-aware equaliser (see module docstring).

    Parameters (``RobustElkoBeamformer.Params``): the fields of ``eb-subband``
    (:class:`enhancers.beam.subband_eb.SubbandElkoBeamformer`) with the gate on
    (``adapt_gate_db=3``, ``gate_floor_s=1``) and the noise-aware EQ on
    (``eq_noise_gain_db=9``, ``eq_highpass_hz=80``, ``eq_phase=True``) and the DAS fallback on
    (``das_mix=True``, ``mix_lam=0.99``, ``mix_smooth_bins=8``, ``mix_alpha0=0.5``), plus those of ``mic-calibration``
    (:class:`enhancers.beam.mic_calibration.MicCalibration`).  ``calibrate=False`` skips step 1.

    Examples
    --------
    >>> import numpy as np, enhancers
    >>> e = enhancers.make("eb-robust")
    >>> e.process(np.random.default_rng(0).standard_normal((2, 8000)), 16000).output.shape
    (1, 8000)
    """

    name: ClassVar[str] = "eb-robust"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "mic self-calibration + sub-band Elko beamformer + noise-aware equaliser"

    @dataclass(frozen=True)
    class Params(SubbandEbParams, CalibrationParams):
        adapt_gate_db: float | None = 3.0
        gate_floor_s: float = 1.0
        eq_noise_gain_db: float | None = 9.0
        eq_highpass_hz: float = 80.0
        eq_phase: bool = True
        das_mix: bool = True
        mix_lam: float = 0.99
        mix_smooth_bins: int = 8
        mix_alpha0: float = 0.5
        calibrate: bool = True

        def __post_init__(self):
            self._check_subband()
            self._check_calibration()
            if not isinstance(self.calibrate, bool):
                raise ParameterError("calibrate", self.calibrate, "True or False")

    def _algo_init(self, fs, n_bins):
        p = self.params
        if fast_frames.COMPILED and fast_frames.kernel_supports(p):  # the compiled step
            return self._fast_state(fs, n_bins, band=_band(p, fs) if p.calibrate else None)
        return (calibration_init(n_bins), subband_init(n_bins, float(p.beta0)))

    def _frames(self, X, algo, fs):
        if isinstance(algo, fast_frames.FastState):  # the compiled step (enhancers.kernels.frames)
            Y, record = algo.frames(X)
            return Y[None], algo, record
        cal, sub = algo
        X1, X2 = X[0], X[1]
        record = {}
        mix_frozen = mix_learn = None
        if self.params.calibrate:
            learn_out = [] if "delayed" in (self.params.mix_model, self.params.beta_model) else None
            r_hat, card, talker, cal = calibration_masks_step(X1, X2, cal, self.params, fs=fs,
                                                             delay=self.delay_samples(fs), learn_out=learn_out)
            X2 = X2 / r_hat
            if learn_out is not None:  # the calibration's weights of the frames it averaged now (D behind)
                mix_learn = tuple(np.concatenate([pair[i] for pair in learn_out]) for i in range(2))
            # the DAS mix learns only where the calibration does too (no talker); beta keeps its own gate
            mix_frozen = card | talker
            record.update(r_hat=r_hat, frozen=mix_frozen)
        Y, beam, sub = self._beamform(X1, X2, sub, fs, mix_frozen=mix_frozen, mix_learn=mix_learn)
        record.update(beam)
        return Y[None], (cal, sub), record

    def _apply(self, record, X, fs):
        X2 = X[1] / record["r_hat"] if "r_hat" in record else X[1]
        return self._apply_beam(X[0], X2, record, fs)[None]

    def _trace(self, record):
        trace = {k: record[k] for k in ("beta", "alpha") if k in record}
        if "r_hat" in record:
            trace.update(calibration_trace(record))
        return trace


class EbRobustSs(Chain):
    """``eb-robust`` then ``ss``: the robust beamformer's one channel feeds spectral subtraction."""

    name = "eb-robust-ss"
    version = "1"
    summary = "robust sub-band beamformer (calibration, noise-aware EQ) followed by spectral subtraction"
    stages = (("eb", "eb-robust"), ("ss", "ss"))


class TalkerBlindRobustEb(RobustElkoBeamformer):
    """``eb-robust`` learning only where the talker is absent (``"eb-robust-blind"``, issue 16).

    The same algorithm and fields as ``eb-robust``, with the defaults of
    :data:`enhancers.beam.presets.EB_ROBUST_BLIND` (what it changes and what it measured is there).

    >>> import enhancers
    >>> e = enhancers.make("eb-robust-blind")
    >>> e.params.beta_model, e.params.frame_start_s, enhancers.make("eb-robust").params.beta_model
    ('delayed', 0.13, 'bin')
    """

    name: ClassVar[str] = "eb-robust-blind"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "eb-robust that learns only where the talker is absent (issue 16: talker-blind)"
    Params = params_with_defaults(RobustElkoBeamformer.Params, "TalkerBlindRobustEb", EB_ROBUST_BLIND, __name__)


class EbRobustBlindSs(Chain):
    """``eb-robust-blind`` then ``ss`` with its gain averaged over bins and frames (``"eb-robust-blind-ss"``;
    the ss stage's defaults are :data:`enhancers.beam.presets.EB_ROBUST_BLIND_SS`)."""

    name = "eb-robust-blind-ss"
    version = "1"
    summary = "talker-blind robust beamformer followed by spectral subtraction with an averaged gain"
    stages = (("eb", "eb-robust-blind"), ("ss", "ss"))
    stage_defaults = {"ss": EB_ROBUST_BLIND_SS}
