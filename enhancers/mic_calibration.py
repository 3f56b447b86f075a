"""Self-calibration of the rear microphone against the front one, per STFT bin (``"mic-calibration"``).

Model: the rear mic's signal is its ideal signal times an unknown, slowly varying complex
response ``r(f)`` relative to the front mic (sensitivity, phase, unequal high-pass corners:
algorithms.md section 4b).  The stage estimates ``r`` per bin from what a phone has
-- noise reaching both mics from the far field or diffusely -- and outputs
``[X1, X2 / r_hat]`` (2 channels).

Estimator.  One-pole averages over the frames that are *not frozen* (time constant
``tau_s``, default 1 s; per-frame factor ``lam = exp(-hop / (fs tau_s))``)::

    S11 = <|X1|^2>,   S22 = <|X2|^2>,   S21 = <X2 conj(X1)>

* Gain: for a far-field source and for a diffuse field both mics receive the same
  power, so ``|r| = sqrt(S22 / S11)`` (near-field sources break this: see the freeze rule).
* Phase: for a diffuse field ``S21 = r S sinc(2 f d / c)`` with a real, positive sinc
  (below ``c / 2d``, 8 kHz for 2.14 cm), so ``angle(S21) = angle(r)``.  A far-field source
  from ``theta`` adds the propagation phase ``-w tau`` (``tau = T cos(theta)``), linear in
  frequency; a mismatch phase is not (constant, or ~1/f from unequal high-pass corners).
  The slope is estimated per frame from the lag-one product across bins,
  ``b = angle(sum_k S21[k+1] conj(S21[k]))`` over ``fit_band_hz`` (default 500-4000 Hz,
  where the high-pass corners' phase has flattened), clipped to the physical range
  ``|b| <= 2 pi T fs / N``, and removed: ``phi_k = angle(S21[k] e^{-j b k})``.  A single
  far-field source and its mismatch cannot be separated otherwise (the issue's point); the
  separation here rests on the mismatch not being linear in frequency, and it is exact for
  a constant phase offset.
* Both are smoothed across ``2 smooth_bins + 1`` neighbouring bins (per band), clipped to
  ``+-max_gain_db`` and ``+-max_phase_deg``: ``r_hat = |r| e^{j phi}``.

Freeze rule.  The talker is in front of the phone (near field at the mouth, or far field
in the look half-plane); its gain ratio is not 1 in the near field and its propagation
phase would be mistaken for mismatch, so the averages stop while it dominates.  Per frame,
``q = 10 log10(sum P_F / sum P_B)`` of the *uncalibrated* forward/backward cardioids over
``fit_band_hz`` (one-pole smoothed, ``gate_lam`` per frame): diffuse noise gives ~0 dB,
a rear source < 0 dB, a frontal talker clearly > 0 dB (a mismatch pushes every source
towards 0 dB, so the rule also works before calibration).  Frozen where
``q > min(floor, 0) + freeze_db`` (``floor``: running minimum of ``q`` over ``floor_s``),
the rule of ``eb-gated``.  While frozen, ``r_hat`` holds.

The estimate applied to frame ``l`` includes frame ``l``.  Everything is vectorised: the
freeze decisions come first (they do not depend on ``r_hat``), the averages are one
:func:`scipy.signal.lfilter` over the active frames, held through frozen ones.

``trace``: ``"rear_gain_db"``, ``"rear_phase_deg"`` (``(n_frames, n_bins)``, the applied
estimate) and ``"frozen"`` (``(n_frames,)``, 1.0 where the averages were frozen).
Latency ``frame_len - 1`` samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.ndimage import minimum_filter1d, uniform_filter1d

from enhancers.stft_stage import TINY, StftEnhancer, StftParams, bin_omega, smooth_frames
from scenesim.errors import ParameterError
from scenesim.validate import check_int, check_range

__all__ = ["CalibrationState", "MicCalibration", "calibration_step"]


@dataclass(frozen=True)
class CalibrationState:
    """Streaming state: averages ``(3, K)`` (S11, S22, S21), freeze smoother and floor history."""

    avg: np.ndarray          # complex (3, K)
    q_e: np.ndarray          # (2,) smoothed band powers of cF, cB
    q_hist: np.ndarray | None = None  # (n_window - 1,) last freeze ratios (dB)


@dataclass(frozen=True)
class CalibrationParams(StftParams):
    """Fields of the calibration estimator (shared by ``mic-calibration`` and ``eb-robust``)."""

    tau_s: float = 1.0
    fit_band_hz: tuple[float, float] = (500.0, 4000.0)
    smooth_bins: int = 1
    max_gain_db: float = 6.0
    max_phase_deg: float = 30.0
    freeze_db: float = 3.0
    gate_lam_cal: float = 0.9
    floor_s: float = 1.0

    def _check_calibration(self):
        self._check_stft()
        check_range("tau_s", self.tau_s, 0.0, 600.0, lo_open=True)
        band = self.fit_band_hz
        if not (isinstance(band, tuple) and len(band) == 2):
            raise ParameterError("fit_band_hz", band, "a pair (lo_hz, hi_hz)")
        lo = check_range("fit_band_hz", band[0], 0.0, 1e5)
        check_range("fit_band_hz", band[1], lo, 1e5, lo_open=True)
        check_int("smooth_bins", self.smooth_bins, minimum=0, maximum=64)
        check_range("max_gain_db", self.max_gain_db, 0.0, 40.0)
        check_range("max_phase_deg", self.max_phase_deg, 0.0, 180.0)
        check_range("freeze_db", self.freeze_db, -60.0, 60.0)
        check_range("gate_lam_cal", self.gate_lam_cal, 0.0, 1.0, hi_open=True)
        check_range("floor_s", self.floor_s, 0.0, 60.0)


def calibration_init(n_bins: int) -> CalibrationState:
    return CalibrationState(avg=np.zeros((3, n_bins), dtype=complex), q_e=np.zeros(2))


def _band(p: CalibrationParams, fs: int) -> slice:
    n = int(p.frame_len)
    k_lo = max(1, int(math.ceil(p.fit_band_hz[0] * n / fs)))
    k_hi = min(n // 2 - 1, int(math.floor(p.fit_band_hz[1] * n / fs)))
    return slice(k_lo, max(k_hi, k_lo + 1) + 1)


def _freeze(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float, band: slice):
    """Frames where the averages stop (a frontal source dominates): ``(frozen (F,), changes)``."""
    ph = np.exp(-1j * bin_omega(int(p.frame_len))[band] * delay)
    cF = X1[:, band] - ph * X2[:, band]
    cB = X2[:, band] - ph * X1[:, band]
    e = np.stack([np.sum(cF.real**2 + cF.imag**2, axis=1), np.sum(cB.real**2 + cB.imag**2, axis=1)], axis=1)
    e = smooth_frames(e, float(p.gate_lam_cal), state.q_e)
    q = 10.0 * np.log10((e[:, 0] + TINY) / (e[:, 1] + TINY))
    changes = {"q_e": e[-1].copy()}
    n_window = int(math.ceil(float(p.floor_s) * fs / int(p.hop))) if p.floor_s > 0 else 0
    ref = np.zeros_like(q)
    if n_window > 1:
        hist = np.full(n_window - 1, np.inf) if state.q_hist is None else state.q_hist
        full = np.concatenate([hist, q])
        floor = minimum_filter1d(full, n_window, origin=(n_window - 1) // 2, mode="constant", cval=np.inf)
        ref = np.minimum(floor[n_window - 1:], 0.0)
        changes["q_hist"] = full[full.shape[0] - (n_window - 1):].copy()
    elif n_window == 1:
        ref = np.minimum(q, 0.0)
    return q > ref + float(p.freeze_db), changes


def estimate_from_averages(avg: np.ndarray, *, band: slice, max_slope: float, smooth_bins: int,
                           max_gain_db: float, max_phase_deg: float) -> np.ndarray:
    """``r_hat (F, K)`` from averages ``avg (F, 3, K)`` = (S11, S22, S21) (see module docstring)."""
    s11, s22, s21 = avg[:, 0].real, avg[:, 1].real, avg[:, 2]
    lag = np.sum(s21[:, band.start + 1:band.stop] * np.conj(s21[:, band.start:band.stop - 1]), axis=1)
    slope = np.clip(np.angle(lag), -max_slope, max_slope)  # rad per bin; angle(0) = 0 on silence
    derot = s21 * np.exp(-1j * slope[:, None] * np.arange(s21.shape[1])[None, :])
    if smooth_bins > 0:
        size = 2 * smooth_bins + 1
        derot = (uniform_filter1d(derot.real, size, axis=1, mode="nearest")
                 + 1j * uniform_filter1d(derot.imag, size, axis=1, mode="nearest"))
        s11 = uniform_filter1d(s11, size, axis=1, mode="nearest")
        s22 = uniform_filter1d(s22, size, axis=1, mode="nearest")
    gain_db = np.clip(10.0 * np.log10((s22 + TINY) / (s11 + TINY)), -max_gain_db, max_gain_db)
    phase = np.clip(np.angle(derot), -math.radians(max_phase_deg), math.radians(max_phase_deg))
    return 10.0 ** (gain_db / 20.0) * np.exp(1j * phase)


def calibration_step(X1, X2, state: CalibrationState, p: CalibrationParams, *, fs: int, delay: float):
    """Estimate ``r_hat`` for the frames of one block.

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
    r_hat : complex (F, K); frozen : bool (F,); new state.
    """
    F, K = X1.shape
    if F == 0:
        return np.ones((0, K), dtype=complex), np.zeros(0, dtype=bool), state
    band = _band(p, fs)
    frozen, changes = _freeze(X1, X2, state, p, fs=fs, delay=delay, band=band)
    lam = math.exp(-int(p.hop) / (fs * float(p.tau_s)))
    active = np.flatnonzero(~frozen)
    x = np.stack([X1.real**2 + X1.imag**2, X2.real**2 + X2.imag**2, X2 * np.conj(X1)], axis=1)[active]
    # the averages move only on active frames: filter those, then hold the value through frozen frames
    avg_active = smooth_frames(x.astype(complex), lam, state.avg)
    held = np.concatenate([state.avg[None], avg_active], axis=0)
    avg = held[np.cumsum(~frozen)]
    max_slope = 2 * math.pi * delay / int(p.frame_len)
    r_hat = estimate_from_averages(avg, band=band, max_slope=max_slope, smooth_bins=int(p.smooth_bins),
                                   max_gain_db=float(p.max_gain_db), max_phase_deg=float(p.max_phase_deg))
    values = dict(vars(state))
    values.update(avg=held[-1].copy(), **changes)
    return r_hat, frozen, CalibrationState(**values)


def calibration_trace(record: dict) -> dict:
    r = record["r_hat"]
    return {"rear_gain_db": 20.0 * np.log10(np.abs(r)), "rear_phase_deg": np.degrees(np.angle(r)),
            "frozen": record["frozen"].astype(float)}


class MicCalibration(StftEnhancer):
    """Rear-mic self-calibration: outputs ``[front, rear / r_hat]`` (see module docstring).

    Parameters (``MicCalibration.Params``)
    --------------------------------------
    spacing_m, c_mps : pair spacing (m), speed of sound (m/s).
    frame_len, hop, window : WOLA filter bank (default 256 / 128 / Hamming).
    tau_s : time constant of the averages over active frames (default 1 s).
    fit_band_hz : band of the propagation-slope estimate and of the freeze rule (default 500-4000 Hz).
    smooth_bins : the estimate is averaged over ``2 smooth_bins + 1`` bins (default 1).
    max_gain_db, max_phase_deg : clip of the estimate (default 6 dB, 30 deg).
    freeze_db, gate_lam_cal, floor_s : freeze rule (default 3 dB above the 1-s floor; smoothing 0.9 per frame).

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
        return calibration_init(n_bins)

    def _frames(self, X, algo, fs):
        r_hat, frozen, algo = calibration_step(X[0], X[1], algo, self.params, fs=fs, delay=self.delay_samples(fs))
        return np.stack([X[0], X[1] / r_hat]), algo, {"r_hat": r_hat, "frozen": frozen}

    def _apply(self, record, X, fs):
        return np.stack([X[0], X[1] / record["r_hat"]])

    def _trace(self, record):
        return calibration_trace(record)
