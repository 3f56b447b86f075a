"""Rear-mic self-calibration (``mic-calibration``) recovers a known complex mismatch and holds still
while a near-field talker speaks.

Oracle: the mismatch applied by ``mismatch.apply_mismatch`` (rear mic times 10^(g/20) e^{j phi} and
first-order high-passes H(f) = jf/(fc + jf) per mic); its exact response ratio ``mismatch.rear_response``.
Fields: ``scenesim.scene.noise_fields.diffuse_noise`` (sinc coherence), ``signals.plane_wave_pair`` (exact
delays), ``scenesim.scene.freefield.point_source`` (near-field talker, 1/(4 pi R) and exact distances).
"""

from __future__ import annotations

import numpy as np
import pytest
from mismatch import apply_mismatch, rear_response
from signals import FS, SPACING_M, plane_wave_pair

from data_recipes.artificial_voice import artificial_voice
from enhancers.core.registry import make
from scenesim.scene.freefield import point_source
from scenesim.scene.geometry import MicPair
from scenesim.scene.noise_fields import diffuse_noise

MISMATCH = dict(gain_db=1.0, phase_deg=5.0, highpass_hz=(80.0, 120.0))
F_HZ = np.arange(129) * FS / 256
TRUTH = rear_response(F_HZ, **MISMATCH)


def _final_estimate(trace, last_frames=125):
    """Mean gain (dB) and phase (deg) per bin over the last second of frames."""
    return (trace["rear_gain_db"][-last_frames:].mean(axis=0), trace["rear_phase_deg"][-last_frames:].mean(axis=0))


def _errors(trace, lo_hz, hi_hz):
    g, p = _final_estimate(trace)
    band = (F_HZ >= lo_hz) & (F_HZ <= hi_hz)
    return (np.max(np.abs(g[band] - 20 * np.log10(np.abs(TRUTH[band])))),
            np.max(np.abs(p[band] - np.degrees(np.angle(TRUTH[band])))))


@pytest.fixture(scope="module")
def diffuse_trace():
    rng = np.random.default_rng(21)
    x = apply_mismatch(diffuse_noise(8 * FS, SPACING_M, fs=FS, rng=rng), fs=FS, **MISMATCH)
    return make("mic-calibration").process(x, FS).trace


@pytest.mark.parametrize("lo_hz, hi_hz, gain_tol_db, phase_tol_deg", [
    (100, 1000, 0.2, 1.5), (1000, 4000, 0.35, 4.0), (4000, 7000, 0.5, 6.0)])
def test_recovers_mismatch_in_diffuse_noise(diffuse_trace, lo_hz, hi_hz, gain_tol_db, phase_tol_deg):
    """1 dB, 5 deg and high-pass corners 80/120 Hz (phase -20 deg at 100 Hz) in 8 s of white diffuse noise:
    per-bin error of the last second's estimate within the stated tolerance (measured 0.17 dB / 1.1 deg,
    0.25 dB / 2.2 deg, 0.34 dB / 5.5 deg; the phase of a diffuse field's cross-spectrum is noisier where its
    coherence sinc(2fd/c) is low: 0.64 at 4 kHz, 0.14 at 7 kHz; and ~75 % of the bins are frozen by the
    floor-relative rule in stationary noise, see the module docstring)."""
    gain_err, phase_err = _errors(diffuse_trace, lo_hz, hi_hz)
    assert gain_err <= gain_tol_db and phase_err <= phase_tol_deg


@pytest.mark.parametrize("theta", [135, 240])
def test_recovers_mismatch_from_one_far_field_source(theta):
    """One far-field white-noise plane wave (the hard case: direction and mismatch share the cross-spectrum);
    the propagation slope is removed: per-bin error within 0.2 dB / 1.2 deg from 100 Hz to 7 kHz (measured
    0.17 dB / 0.97 deg, largest near the high-pass corners)."""
    x = apply_mismatch(plane_wave_pair(np.random.default_rng(22).standard_normal(8 * FS), az_deg=theta),
                       fs=FS, **MISMATCH)
    gain_err, phase_err = _errors(make("mic-calibration").process(x, FS).trace, 100, 7000)
    assert gain_err <= 0.2 and phase_err <= 1.2


def _noise_then_talker():
    """6 s of diffuse noise, then 4 s with a near-field talker (5 cm at 30 deg) 10 dB above it."""
    rng = np.random.default_rng(23)
    n_noise, n_talk = 6 * FS, 4 * FS
    noise = diffuse_noise(n_noise + n_talk, SPACING_M, fs=FS, rng=rng)
    pair = MicPair()
    voice, _ = artificial_voice(4.0, fs=FS, seed=5)
    talk = point_source(voice, pair, position_m=pair.source_position(30.0, 0.05), fs=FS)
    talk *= np.sqrt(10 * np.mean(noise[0] ** 2) / np.mean(talk[0] ** 2))
    x = noise.copy()
    x[:, n_noise:] += talk
    return apply_mismatch(x, fs=FS, **MISMATCH), n_noise // 128


@pytest.mark.parametrize("freeze", [True, False])
def test_estimate_stays_put_while_near_field_talker_speaks(freeze):
    """Converged on noise, the estimate moves by <= 0.15 dB / 1 deg (300 Hz-4 kHz, mean over the band of the
    absolute change; measured 0.06 dB / 0.46 deg) during 4 s of a near-field talker 5 cm away at +10 dB
    (whose level differs by ~3 dB between the mics).  Control: with both freeze rules disabled it moves by
    more than 0.5 dB (measured 1.6 dB)."""
    x, onset = _noise_then_talker()
    kw = {} if freeze else {"freeze_db": 60.0, "freeze_band_db": 60.0}
    tr = make("mic-calibration", **kw).process(x, FS).trace
    band = (F_HZ >= 300) & (F_HZ <= 4000)
    g, p = tr["rear_gain_db"][:, band], tr["rear_phase_deg"][:, band]
    dg = np.mean(np.abs(g[-1] - g[onset - 1]))
    dp = np.mean(np.abs(p[-1] - p[onset - 1]))
    if freeze:
        assert dg <= 0.15 and dp <= 1.0
    else:
        assert dg > 0.5


def test_vectorised_step_matches_slow_reference():
    """calibration_step (vectorised, fed in three blocks) == the loop reference of tests/subband_reference.py
    (freeze rules, per-bin averages, slope fit, band smoothing) to 1e-9 in r_hat, identical freeze masks.
    Small config (64-point frames, 40 frames, 0.1 s floor) on a diffuse field plus a frontal burst; the
    reference has the two cardioid rules (the default: the talker-blind level rule and ramp off)."""
    from subband_reference import calibration_reference

    from enhancers.beam.mic_calibration import (
        MicCalibration,
        _band,
        calibration_init,
        calibration_step,
    )

    rng = np.random.default_rng(24)
    e = MicCalibration(frame_len=64, hop=32, tau_s=0.05, floor_s=0.1, estimate_every=3, fit_band_hz=(700.0, 5000.0))
    p = e.params
    x = apply_mismatch(diffuse_noise(40 * 32, SPACING_M, fs=FS, rng=rng), fs=FS, **MISMATCH)
    x[:, 600:900] += 3 * plane_wave_pair(rng.standard_normal(300), az_deg=10)
    X = e.filterbank.analyze(x)
    delay = e.delay_samples(FS)
    band = _band(p, FS)
    expected, frozen_ref = calibration_reference(
        X[0], X[1], delay=delay, frame_len=64, band=(band.start, band.stop - 1), tau_frames=0.05 * FS / 32,
        lam_gate=p.gate_lam_cal, n_window=int(np.ceil(0.1 * FS / 32)), freeze_db=p.freeze_db,
        freeze_band_db=p.freeze_band_db, every=3, smooth_bins=p.smooth_bins, smooth_frac=p.smooth_frac,
        max_gain_db=p.max_gain_db, max_phase_deg=p.max_phase_deg, min_coherence=p.min_coherence,
        phase_leak=p.phase_leak)
    state, parts, masks = calibration_init(X.shape[2]), [], []
    for lo, hi in ((0, 7), (7, 8), (8, X.shape[1])):
        r, fr, state = calibration_step(X[0, lo:hi], X[1, lo:hi], state, p, fs=FS, delay=delay)
        parts.append(r)
        masks.append(fr)
    frozen = np.concatenate(masks)
    assert 0.1 < frozen_ref.mean() < 0.9  # both rules are exercised
    np.testing.assert_array_equal(frozen, frozen_ref)
    np.testing.assert_allclose(np.concatenate(parts), expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("min_coherence", [0.3, 0.0])
def test_phase_does_not_wander_in_incoherent_noise(min_coherence):
    """Spatially white noise (self-noise only: nothing to measure a phase from): the estimated phase stays
    within 4 deg of 0 over the last 5 s of 10 s (measured 3.1 deg; 2.1 with another seed).  Control: without
    the coherence rule (min_coherence=0) it walks to the 30 deg clip."""
    x = np.random.default_rng(25).standard_normal((2, 10 * FS))
    phase = np.abs(make("mic-calibration", min_coherence=min_coherence).process(x, FS).trace["rear_phase_deg"])
    if min_coherence > 0:
        assert phase[-600:].max() <= 4.0
    else:
        assert phase[-600:].max() >= 29.0


def _talker_bursts(seed: int, *, other: bool = False):
    """``(s, n)``, ``(2, 6 s)`` each, mismatched rear mic: white diffuse noise and a speech-like talker at
    45 deg (far field) 20 dB above it in two bursts, 1-1.5 s and 3-3.5 s, exactly zero elsewhere.
    ``other``: another talker (a 110 Hz voice and a 3x louder one) in the same bursts."""
    from signals import harmonic_speechlike

    rng = np.random.default_rng(seed)
    n = 6 * FS
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    t = np.arange(n) / FS
    # the bursts, and inside them the voice's own pause (the second half of every second, where its
    # 4 Hz syllable envelope has just come down to 0: smooth offsets, as speech has)
    on = ((t >= 1.0) & (t < 1.5)) | ((t >= 3.0) & (t < 3.5))
    voice = harmonic_speechlike(n, f0_hz=110.0, pause_s=0.5) * 3.0 if other else harmonic_speechlike(n, pause_s=0.5)
    # gated after the (circular) delay and the mismatch filters: exactly zero outside the bursts
    talk = apply_mismatch(plane_wave_pair(voice, az_deg=45), fs=FS, **MISMATCH) * on
    talk *= np.sqrt(100 * np.mean(noise[0] ** 2) / np.mean(talk[0, on] ** 2))
    return talk, apply_mismatch(noise, fs=FS, **MISMATCH)


def _two_runs(partner: str, **params):
    """The calibration's traces on ``s + n`` and on its partner, and the replays of ``s``."""
    s, n = _talker_bursts(31)
    x2 = s - n if partner == "s - n" else _talker_bursts(31, other=True)[0] + n
    e = make("mic-calibration", **params)
    r1, r2 = e.process(s + n, FS), e.process(x2, FS)
    return r1, r2, s


# frames up to 0.1 s after the first burst: 1.6 s
FIRST_BURST_DONE = int(1.6 * FS / 128)


@pytest.mark.parametrize("partner", ["s - n", "other talker"])
def test_cardioid_rules_alone_listen_to_the_talker(partner):
    """The control of :func:`test_frame_rule_ignores_the_talker` (the default): with only the two
    cardioid-ratio freeze rules (``frame_q_db=None``, no start-up ramp) the cells they leave open during the burst
    carry the talker (and its cross term with the noise, which changes sign with the noise): the two runs'
    estimates differ already by the end of the first burst (by more than 1e-3 dB in some bin)."""
    r1, r2, _ = _two_runs(partner)
    m = FIRST_BURST_DONE
    assert np.max(np.abs(r2.trace["rear_gain_db"][:m] - r1.trace["rear_gain_db"][:m])) > 1e-3


def _assert_blocks_match_one_pass(e, x, splits):
    """Streaming :func:`calibration_step` over the frame ranges ``splits`` (then the rest) == one pass over the
    frames of ``x (2, n)``, estimates to 1e-12 and masks exactly (the carried state is complete)."""
    from enhancers.beam.mic_calibration import calibration_init, calibration_step

    X = e.filterbank.analyze(x)
    delay = e.delay_samples(FS)
    whole, fr_whole, _ = calibration_step(X[0], X[1], calibration_init(X.shape[2]), e.params, fs=FS, delay=delay)
    state, parts, masks = calibration_init(X.shape[2]), [], []
    edges = [0, *splits, X.shape[1]]
    for lo, hi in zip(edges[:-1], edges[1:]):
        r, fr, state = calibration_step(X[0, lo:hi], X[1, lo:hi], state, e.params, fs=FS, delay=delay)
        parts.append(r)
        masks.append(fr)
    np.testing.assert_array_equal(np.concatenate(masks), fr_whole)
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-12)


def test_rear_rule_learns_under_a_rising_rear_source():
    """``cal_rear_db`` (with the frame rule): a rear plane wave (150 deg); after 2 s the rear mic drifts to the
    1 dB / 5 deg mismatch while the source grows by 6 dB per second (a machine starting up), which keeps the
    frame rule's level part (``frame_level_db=3``: 3 dB over its 3-s minimum) firing: the calibration, frozen,
    keeps its first estimate (0 dB) and ends >= 0.5 dB off at 500 Hz-2 kHz (measured 0.85); the rear rule (backward/forward
    power >= 10 dB over the band) certifies those cells as talker-free, so it follows the drift: within
    0.2 dB (measured 0.005)."""
    rng = np.random.default_rng(41)
    n0, n1 = 2 * FS, 4 * FS
    quiet = plane_wave_pair(rng.standard_normal(n0), az_deg=150)
    rising = plane_wave_pair(10 ** (6.0 * np.arange(n1) / FS / 20) * rng.standard_normal(n1), az_deg=150)
    x = np.concatenate([quiet, apply_mismatch(rising, fs=FS, **MISMATCH)], axis=1)
    band = (F_HZ >= 500) & (F_HZ <= 2000)
    truth_db = 20 * np.log10(np.abs(TRUTH[band]))
    errs = {}
    for rear in (None, 10.0):
        e = make("mic-calibration", frame_q_db=5.0, frame_level_db=3.0, cal_rear_db=rear)
        g, _ = _final_estimate(e.process(x, FS).trace)
        errs[rear] = np.max(np.abs(g[band] - truth_db))
    assert errs[None] >= 0.5 and errs[10.0] <= 0.2, errs
# model="hp1": the 4-parameter sensor model (enhancers.beam.calibration_model) instead of per-bin averages
@pytest.fixture(scope="module")
def diffuse_trace_hp1():
    rng = np.random.default_rng(21)
    x = apply_mismatch(diffuse_noise(8 * FS, SPACING_M, fs=FS, rng=rng), fs=FS, **MISMATCH)
    return make("mic-calibration", model="hp1").process(x, FS).trace


@pytest.mark.parametrize("prior", [1000.0, 1.0])
def test_model_prior_holds_the_estimate_in_incoherent_noise(prior):
    """``model="hp1"`` in spatially white noise (nothing to measure a phase from, and powers equal only on
    average): with the default prior (``model_prior=1000``) the estimate stays within 2 deg / 0.6 dB of
    ``r = 1`` over the last 5 s of 10 s (measured 0.82 deg / 0.32 dB; the per-bin estimate 3.1 deg /
    0.94 dB).  Control: with a prior of 1 (a few cells' worth) the fit follows the noise to more than
    5 deg (measured 7.5 deg / 2.3 dB: the corners, which only the lowest bins see, wander)."""
    x = np.random.default_rng(25).standard_normal((2, 10 * FS))
    tr = make("mic-calibration", model="hp1", model_prior=prior).process(x, FS).trace
    phase, gain = np.abs(tr["rear_phase_deg"][-600:]).max(), np.abs(tr["rear_gain_db"][-600:]).max()
    if prior > 1:
        assert phase <= 2.0 and gain <= 0.6
    else:
        assert phase > 5.0


@pytest.mark.parametrize("lo_hz, hi_hz", [(100, 1000), (1000, 4000), (4000, 7000)])
def test_model_recovers_mismatch_in_diffuse_noise(diffuse_trace_hp1, lo_hz, hi_hz):
    """``model="hp1"``, the scene of :func:`test_recovers_mismatch_in_diffuse_noise` (oracle: the closed-form
    ``r(f)`` of the applied mismatch, which the model can represent exactly): per-bin error of the last
    second's estimate within 0.1 dB / 1.2 deg in every band (measured 0.05 dB / 0.96 deg, 0.03 / 0.85,
    0.03 / 0.86 -- the prior, ``model_prior=1000``, still pulls the phase towards 0 a little; with
    ``model_prior=1`` 0.04 / 0.42, 0.02 / 0.23, 0.02 / 0.24; the per-bin estimate's 0.17 / 1.1, 0.25 / 2.2,
    0.34 / 5.5; with the default Cauchy weights 0.05 / 1.02, 0.04 / 0.9, 0.04 / 0.9).  Above 4 kHz the model extrapolates its fit from 100 Hz-4 kHz (the sensor model has
    nothing there but the gain and phase)."""
    gain_err, phase_err = _errors(diffuse_trace_hp1, lo_hz, hi_hz)
    assert gain_err <= 0.1 and phase_err <= 1.2


@pytest.mark.parametrize("theta", [135, 240])
def test_model_recovers_mismatch_from_one_far_field_source(theta):
    """``model="hp1"``, the scene of :func:`test_recovers_mismatch_from_one_far_field_source` (the propagation
    slope removed first): per-bin error within 0.05 dB / 0.6 deg from 100 Hz to 7 kHz (measured 0.02 dB /
    0.42-0.45 deg, 0.01 dB / 0.12-0.16 deg with ``model_prior=1``; the per-bin estimate's 0.17 dB / 0.97 deg)."""
    x = apply_mismatch(plane_wave_pair(np.random.default_rng(22).standard_normal(8 * FS), az_deg=theta),
                       fs=FS, **MISMATCH)
    gain_err, phase_err = _errors(make("mic-calibration", model="hp1").process(x, FS).trace, 100, 7000)
    assert gain_err <= 0.05 and phase_err <= 0.6


SENSORS = dict(gain_db=1.0, phase_deg=5.0, highpass_hz=(60.0, 140.0))
THETA_TRUE = np.array([np.log(10 ** (1 / 20)), np.radians(5.0), np.log(60.0), np.log(140.0), 0.0])


def test_fit_recovers_sensor_parameters_from_exact_log_response():
    """``calibration_model.fit_hp1`` from the prior (equal 100 Hz corners) on the exact ``ln r`` of 1 dB, 5 deg,
    corners 60 / 140 Hz (``mismatch.rear_response``, independent of the model code) at 125 Hz-4 kHz, equal
    weights: recovers ``ln g`` and ``phi0`` to 1e-4, ``ln fc1``, ``ln fc2`` to 2e-3 (0.2 %) and the nuisance
    slope to 2e-3 of 0 (measured 6e-6, 2e-5, 1.5e-3, 7e-4, 6e-6: the prior's pull, weight 1, against the data's weak
    curvature in the corners' common shift -- with equal corners ``r`` would not depend on it at all)."""
    from enhancers.beam.calibration_model import fit_hp1

    f = F_HZ[2:65]
    log_r = np.log(rear_response(f, **SENSORS))
    w = np.full(f.shape, 1e4)
    theta = fit_hp1(f, log_r, w, w, n_iter=30)
    np.testing.assert_allclose(theta[:2], THETA_TRUE[:2], rtol=0, atol=1e-4)
    np.testing.assert_allclose(theta[2:], THETA_TRUE[2:], rtol=0, atol=2e-3)  # and no residual slope


@pytest.mark.parametrize("az", [90, 135, 240])
def test_model_recovers_sensor_parameters_from_noiseless_averages(az):
    """``model_estimate`` on the noiseless averages of one far-field plane wave (``S11 = 1``, ``S22 = |r|^2``,
    ``S21 = r e^{-j w T cos(az)}``; ``r``: ``mismatch.rear_response``): the propagation slope is removed, then
    the fit (``model_prior=1``: the data decide) recovers the gain within 0.001 dB, the phase within 0.01 deg
    and the corners within 0.1 Hz (measured 1e-5 dB, 2e-4 deg, 0.02 Hz, the same at every angle: the fit's
    nuisance slope takes up the slope removal's bias -- its ``c / k`` term approximates the corners' phase
    to first order only)."""
    from enhancers.beam.mic_calibration import _band, model_estimate

    e = make("mic-calibration", model="hp1", model_iter=50, model_prior=1.0)
    delay = e.delay_samples(FS)
    r = rear_response(F_HZ, **SENSORS)
    prop = np.exp(-1j * 2 * np.pi * F_HZ / FS * delay * np.cos(np.radians(az)))
    avg = np.stack([np.ones(129), np.abs(r) ** 2, r * prop]).astype(complex)[None]
    _, theta = model_estimate(avg, np.full((1, 129), 250.0), None, e.params, fs=FS, band=_band(e.params, FS),
                              max_slope=2 * np.pi * delay / 256)
    assert abs(theta[0] - THETA_TRUE[0]) * 20 / np.log(10) <= 0.001
    assert abs(np.degrees(theta[1] - THETA_TRUE[1])) <= 0.01
    np.testing.assert_allclose(np.exp(theta[2:4]), [60.0, 140.0], rtol=0, atol=0.1)


def test_blocks_match_one_pass_with_the_model():
    """Streaming (blocks of 1, 5, 37 and the rest) == one pass with ``model="hp1"`` and its pooled ramp: the
    fit's warm start (``CalibrationState.theta``) is carried.  Oracle: the same computation, to 1e-12."""
    s, n = _talker_bursts(32)
    _assert_blocks_match_one_pass(make("mic-calibration", model="hp1", ramp_frames=2000.0), (s + n)[:, : 2 * FS],
                                  (1, 6, 43))


def test_blocks_match_one_pass_with_the_rear_rule():
    """Streaming (blocks of 1, 5, 37 and the rest) == one pass with the rear rule and the frame rule's look
    ahead: the rear decisions of the pending frames (``CalibrationState.pend_rear``) are carried.  Oracle: the
    same computation, to 1e-12 (and masks exactly)."""
    s, n = _talker_bursts(32)
    rear = 0.5 * plane_wave_pair(np.random.default_rng(5).standard_normal(s.shape[1]), az_deg=150)
    e = make("mic-calibration", frame_q_db=5.0, cal_rear_db=6.0, level_ahead_s=0.1, ramp_frames=40.0)
    _assert_blocks_match_one_pass(e, (s + n + rear)[:, : 3 * FS], (1, 6, 43))


def test_robust_fit_ignores_a_few_bins_off_the_model():
    """``fit_hp1(robust=0.05)`` (Cauchy weights): the exact ``ln r`` of :data:`SENSORS` with 5 of 63 bins off by
    +0.3 (2.6 dB) and +0.3 rad (17 deg) -- a talker's harmonics leaking into the averages.  Oracle: the
    closed-form ``r``; the robust fit's worst bin is within 0.02 dB / 0.2 deg of it (measured 0.006 dB /
    0.06 deg); control: plain least squares (``robust=None``) is pulled by more than 0.1 dB / 1 deg
    (measured 0.22 dB / 2.0 deg)."""
    from enhancers.beam.calibration_model import fit_hp1, hp1_log_response

    f = F_HZ[2:65]
    log_r = np.log(rear_response(f, **SENSORS))
    bad = log_r.copy()
    bad[np.arange(3, 63, 12)] += 0.3 + 0.3j
    w = np.full(f.shape, 1e4)
    for robust in (0.05, None):
        err = hp1_log_response(f, fit_hp1(f, bad, w, w, n_iter=30, robust=robust)) - log_r
        gain_db, phase_deg = np.abs(err.real).max() * 20 / np.log(10), np.degrees(np.abs(err.imag).max())
        if robust:
            assert gain_db <= 0.02 and phase_deg <= 0.2
        else:
            assert gain_db > 0.1 and phase_deg > 1.0


# the frame rule (a level-free, frame-level talker detector with a 0.2 s hold and 0.24 s look ahead)
FRAME_RULE = {"frame_q_db": 5.0, "level_hang_s": 0.2, "level_ahead_s": 0.24}


def test_frame_rule_ignores_the_talker():
    """The frame rule: the calibration adapted on ``s + n`` and on ``s - n`` (Hagerman's pair) is the
    same operation through the first burst and the rule's 0.2 s hold after it.  Oracle (closed form): the
    mixtures are identical up to sign wherever the talker is absent, so a rule that learns only there gives identical estimates (1e-12) and ``speech_jitter_db =
    -inf`` over that span.  (Not so for *another* talker in the same cells: the frame where a voice's onset
    crosses the ratio threshold depends on its spectrum above 1 kHz -- 4 frames later for the 110 Hz voice
    here -- and the look ahead then leaves other noise-only frames open: the sets differ, not by the talker.)"""
    from benchmarks.metrics.distortion import speech_jitter_db

    r1, r2, s = _two_runs("s - n", **FRAME_RULE)
    m = int(1.75 * FS / 128)  # the first burst ends at 1.5 s, the hold 0.2 s later
    np.testing.assert_allclose(r2.trace["rear_gain_db"][:m], r1.trace["rear_gain_db"][:m], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r2.trace["rear_phase_deg"][:m], r1.trace["rear_phase_deg"][:m], rtol=0, atol=1e-12)
    span = slice(0, m * 128 - 256)
    assert speech_jitter_db(r1.replay(s)[:, span], r2.replay(s)[:, span]) < -200.0


def _frame_weights_of(x, **params):
    """The frame rule's weights for ``x (2, n)`` (held, as the averages use them, in one pass), per frame from
    the first (the first ``D`` rows the averages reach are the stream start's placeholders; the last ``D``
    frames are not judged yet)."""
    from enhancers.beam.mic_calibration import _frame_weights, calibration_init

    e = make("mic-calibration", **{**FRAME_RULE, **params})
    X = e.filterbank.analyze(x)
    n_ahead = int(round(float(e.params.level_ahead_s) * FS / 128))
    return _frame_weights(X[0], X[1], calibration_init(X.shape[2]), e.params, fs=FS, delay=e.delay_samples(FS),
                          n_ahead=n_ahead, changes={})[0][n_ahead:]


def test_frame_rule_is_blind_to_level_swings_and_sees_the_talker():
    """Closed form: a diffuse field's forward/backward cardioid power ratio is 0 dB at any level, so noise that
    jumps 15 dB up for 1.5 s and down again leaves every frame learned (weight 1; measured max ratio 0.75 dB
    over 48 bins, the threshold is 5 dB); a talker at 45 deg 10 dB above the noise (ratio ~ 10 log10((1 + 2.19
    rho) / (1 + 0.064 rho)) = 11 dB for an ideal cardioid pair) gets weight 0 in all its frames and in the
    0.2 s hold after / 0.24 s look ahead before them, and nowhere else.  Real mismatch (1 dB / 5 deg) on both."""
    rng = np.random.default_rng(5)
    n = 6 * FS
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    gain = np.where((np.arange(n) >= 2 * FS) & (np.arange(n) < int(3.5 * FS)), 10 ** (15 / 20), 1.0)
    swing = apply_mismatch(noise * gain, fs=FS, **MISMATCH)
    w = _frame_weights_of(swing)
    assert w[3:].min() == 1.0
    on = (np.arange(n) >= 4 * FS) & (np.arange(n) < int(4.5 * FS))
    talk = plane_wave_pair(rng.standard_normal(n), az_deg=45) * on
    talk *= np.sqrt(10 * np.mean(noise[0] ** 2) / np.mean(talk[0, on] ** 2))
    w = _frame_weights_of(apply_mismatch(noise + talk, fs=FS, **MISMATCH))
    frames = np.arange(w.size) * 128 / FS  # frame start times (s)
    # the frames from the look ahead before the burst to the hold after it, less the rule's detection lag
    # (the 27 ms smoother and the 16 ms frame overlap: <= 30 ms at either end; measured 8 ms before, 28 ms after)
    held = (frames > 4.0 - 0.24 + 0.03) & (frames < 4.5 + 0.2 - 0.03)
    assert w[held].max() == 0.0
    assert w[(frames < 3.6) | (frames > 4.8)][3:].min() == 1.0


def test_blocks_match_one_pass_with_the_frame_rule():
    """Streaming (blocks of 1, 5, 37 and the rest) == one pass with the frame rule (its smoother, hold and look
    ahead carried between blocks).  Oracle: the same computation, to 1e-12."""
    s, n = _talker_bursts(33)
    _assert_blocks_match_one_pass(make("mic-calibration", **FRAME_RULE), s + n,
                                  [1, 6, 43, 200])


@pytest.mark.parametrize("bad", [{"frame_q_db": 99.0}, {"frame_band_hz": (4000.0, 1000.0)}])
def test_frame_rule_parameters_are_checked(bad):
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError):
        make("mic-calibration", **bad)


def test_frame_snr_share_closed_form():
    """``frame_snr_db = (6, 12)``: the estimate is the power ratio of the talker's frames to the others' (closed
    form ``(S + N) / N``): 10x -> 10 dB -> the frame rule's share (10 - 6) / (12 - 6) = 2/3; 100x -> 1; 2x ->
    0; and 1 (the frame rule alone) until both kinds of frame were seen."""
    from enhancers.beam.mic_calibration import _frame_snr_share

    p = make("mic-calibration", frame_q_db=5.0, frame_snr_db=(6.0, 12.0)).params
    talker = np.array([False] * 5 + [True] * 5)
    for ratio, share in ((10.0, 2.0 / 3.0), (100.0, 1.0), (2.0, 0.0)):
        power = np.where(talker, ratio, 1.0)
        kappa, state = _frame_snr_share(talker, power, None, p, fs=FS)
        np.testing.assert_allclose(kappa[5:], share, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(kappa[:5], 1.0)
        np.testing.assert_allclose(state, [ratio, 5, 1.0, 5], rtol=0, atol=1e-12)


def test_frame_snr_share_grows_with_the_rarer_kind_of_frame():
    """``frame_snr_frames = 4``: the share goes from 1 to the estimate's value linearly in the count of the rarer
    kind of frame.  Closed form: 6 noise frames, then talker frames at 10x (estimate 2/3): at the k-th talker
    frame the share is ``1 - (1/3) min(1, k / 4)`` -- 11/12, 5/6, 3/4, then 2/3 -- where without the option it
    is 2/3 from the first."""
    from enhancers.beam.mic_calibration import _frame_snr_share

    p = make("mic-calibration", frame_q_db=5.0, frame_snr_db=(6.0, 12.0), frame_snr_frames=4.0).params
    talker = np.array([False] * 6 + [True] * 6)
    kappa, _ = _frame_snr_share(talker, np.where(talker, 10.0, 1.0), None, p, fs=FS)
    k = np.arange(1, 7)
    np.testing.assert_allclose(kappa[6:], 1 - np.minimum(1, k / 4) / 3, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(kappa[:6], 1.0)


def _learn_weights(x, **params):
    """``mix_model="delayed"``'s held weights of the calibration inside ``eb-robust`` over ``x``, ``(F, K)``."""
    import enhancers.beam.robust_eb as rb

    seen = []
    original = rb.calibration_masks_step

    def spy(*a, **k):
        out = original(*a, **k)
        seen.extend(k["learn_out"])
        return out

    rb.calibration_masks_step = spy
    try:
        make("eb-robust", mix_model="delayed", mix_bands_hz=(1000.0,), **params).process(x, FS)
    finally:
        rb.calibration_masks_step = original
    return np.concatenate([held for held, _ in seen])


def test_frame_snr_share_switches_between_the_rules():
    """Above its range the share is 1 and the weights are the frame rule's to the last bit (oracle: the same
    arithmetic, ``frame_snr_db=None``); below it they are the cardioid rules' cells, which learn inside the
    talker's bursts as well (measured 1.3 % of the first burst's cells; the frame rule none)."""
    s, n = _talker_bursts(34)
    x = s + n
    frame = _learn_weights(x, **FRAME_RULE)
    high = _learn_weights(x, **FRAME_RULE, frame_snr_db=(-60.0, -50.0))
    low = _learn_weights(x, **FRAME_RULE, frame_snr_db=(50.0, 60.0))
    np.testing.assert_array_equal(high, frame)
    d = int(round(0.24 * FS / 128))
    burst = slice(d + int(1.0 * FS / 128), d + int(1.5 * FS / 128))  # rows of the first burst's frames
    assert frame[burst].max() == 0.0 and low[burst].mean() > 0.01


def _rear_scene(seed: int):
    """:func:`_talker_bursts` plus a rear plane wave (150 deg, 6 dB over the diffuse noise): its cells'
    backward/forward ratio lies on both sides of 6 and 10 dB (at 5x it is over both almost everywhere)."""
    s, n = _talker_bursts(seed)
    return s + n + 2.0 * plane_wave_pair(np.random.default_rng(seed + 1).standard_normal(s.shape[1]), az_deg=150)


def test_rear_low_threshold_follows_the_snr_share():
    """``cal_rear_low_db`` (issue 16): the rear rule's threshold is ``cal_rear_db`` where the frame rule's share
    is 1 (high input SNR) and ``cal_rear_low_db`` where it is 0.  Oracle: the same arithmetic with one
    threshold -- share forced to 1 (``frame_snr_db=(-60, -50)``): the weights of ``cal_rear_db=10`` alone to
    the last bit; forced to 0 (``(50, 60)``): those of ``cal_rear_db=6`` alone.  Control: the two differ in
    this scene at both shares (measured: mean |difference| of the weights 0.038 at share 1, 0.12 at 0), so
    each equality can fail."""
    x = _rear_scene(36)
    rule = dict(FRAME_RULE, cal_rear_db=10.0)
    for share, one in (((-60.0, -50.0), 10.0), ((50.0, 60.0), 6.0)):
        two = _learn_weights(x, **rule, frame_snr_db=share, cal_rear_low_db=6.0)
        np.testing.assert_array_equal(two, _learn_weights(x, **dict(rule, cal_rear_db=one), frame_snr_db=share))
    for share in ((-60.0, -50.0), (50.0, 60.0)):
        hi, lo = (_learn_weights(x, **dict(rule, cal_rear_db=t), frame_snr_db=share) for t in (10.0, 6.0))
        assert np.abs(hi - lo).mean() > 0.02


def test_blocks_match_one_pass_with_the_rear_low_threshold():
    """Streaming (blocks of 1, 5, 37 and the rest) == one pass with both rear thresholds: the pending frames'
    levels (0 / 1 / 2, ``CalibrationState.pend_rear``) and the SNR share are carried.  Oracle: the same
    computation, to 1e-12 (and masks exactly)."""
    e = make("mic-calibration", **FRAME_RULE, frame_snr_db=(6.0, 12.0), cal_rear_db=10.0, cal_rear_low_db=6.0)
    _assert_blocks_match_one_pass(e, _rear_scene(37)[:, : 3 * FS], (1, 6, 43))


def test_graded_rear_rule_tends_to_the_hard_one():
    """``cal_rear_soft_db = g``: a ramp from ``cal_rear_db`` to ``cal_rear_db + g``, the low threshold hard and
    weighted by ``1 - share``.  Oracle: the hard rule (a slow reference of the same arithmetic) -- with
    ``g = 1e-9`` the held weights equal the hard rule's at mixed shares (``frame_snr_db=(6, 12)``), with both
    thresholds and with ``cal_rear_db`` alone, to 1e-12 (a cell's smoothed ratio within 1e-9 dB of 10 dB
    is the only way to differ).  Control: ``g = 3`` differs (measured: mean |difference| of the weights
    0.0056 with both thresholds, 0.0074 with ``cal_rear_db`` alone), so each equality can fail.
    ``cal_rear_lam`` = ``gate_lam_cal`` gives the same weights bit for bit; 0.8 differs (measured 0.019 / 0.025)."""
    x = _rear_scene(41)
    for low in ({"cal_rear_low_db": 6.0}, {}):
        rule = dict(FRAME_RULE, cal_rear_db=10.0, frame_snr_db=(6.0, 12.0), **low)
        hard = _learn_weights(x, **rule)
        np.testing.assert_allclose(_learn_weights(x, **rule, cal_rear_soft_db=1e-9), hard, rtol=0, atol=1e-12)
        soft = _learn_weights(x, **rule, cal_rear_soft_db=3.0)
        assert np.abs(soft - hard).mean() > 0.003
        # cal_rear_lam: the rule's own smoother, gate_lam_cal (0.7) unless given -- the same to the last bit
        np.testing.assert_array_equal(_learn_weights(x, **rule, cal_rear_soft_db=3.0, cal_rear_lam=0.7), soft)
        assert np.abs(_learn_weights(x, **rule, cal_rear_soft_db=3.0, cal_rear_lam=0.8) - soft).mean() > 0.01


def test_blocks_match_one_pass_with_the_graded_edges():
    """Streaming (blocks of 1, 6, 43 and the rest) == one pass with the hold's taper, the graded rear rule and the
    SNR share's clip (``FRAME_TAPER``'s pieces: the longer weight tail, the pending ratios in dB and the
    share's state are carried).  Oracle: the same computation, to 1e-12 (and masks exactly)."""
    e = make("mic-calibration", **FRAME_RULE, frame_snr_db=(6.0, 12.0), cal_rear_db=10.0, cal_rear_low_db=6.0,
             cal_rear_soft_db=3.0, cal_rear_lam=0.8, frame_hold_taper_s=0.05, frame_snr_quiet=True,
             frame_snr_quiet_ratio=True, frame_snr_clip_db=15.0)
    _assert_blocks_match_one_pass(e, _rear_scene(42)[:, : 3 * FS], (1, 6, 43))


def test_hold_taper_moves_an_onset_by_one_frame_weight():
    """``frame_hold_taper_s`` (``R`` frames): a talker heard one frame later changes no held weight by more than
    ``1 / (R + 1)``; the hard hold (``R = 0``) changes a whole frame's, by 1 (closed form of the taper: the
    weight of a frame ``k`` frames outside the hold's core is ``k / (R + 1)``).  Both ends: an onset and an
    end."""
    from enhancers.beam.mic_calibration import _held

    for R in (0, 3, 6):
        w1 = np.ones(120)
        w1[40:60] = 0.0
        w2 = np.ones(120)
        w2[41:61] = 0.0
        d = np.abs(_held(w1, 25, 30, R) - _held(w2, 25, 30, R)).max()
        np.testing.assert_allclose(d, 1.0 / (R + 1), rtol=0, atol=1e-12)


def test_hold_taper_keeps_the_hold_in_place(monkeypatch):
    """The stream's held weights with the taper (``R`` = 6 frames of ``frame_hold_taper_s=0.05``, ``H`` = 25,
    ``D`` = 30): for a talker the rule hears in frames ``a..b`` only, 0 over ``a - (D - R) .. b + H``, and
    ``k / (R + 1)`` at the ``k``-th frame outside that, on either side, up to ``R`` (closed form; the held
    weights run ``D`` frames behind the block's).  Without the taper: 0 over ``a - D .. b + H``.  Oracle for
    the tail's length at the stream start and the window's alignment (a tail ``R`` frames too long shifts
    every held weight by ``R`` frames)."""
    import enhancers.beam.mic_calibration as mc

    a, b, F = 100, 120, 260
    w = np.ones(F)
    w[a:b + 1] = 0.0
    monkeypatch.setattr(mc, "_frame_rule", lambda X1, X2, state, p, **k: (w, None, w < 1, np.ones(F)))
    X = np.zeros((F, 129), dtype=complex)
    D, H = 30, 25  # FRAME_RULE's 0.24 s and 0.2 s at a 128-sample hop
    for R, taper in ((0, 0.0), (6, 0.05)):
        p = make("mic-calibration", **FRAME_RULE, frame_hold_taper_s=taper).params
        held = mc._frame_weights(X, X, mc.calibration_init(129), p, fs=FS, delay=1.0, n_ahead=D, changes={})[0]
        expect = np.ones(F)  # frame j of the stream is held[j + D]
        expect[a - (D - R):b + H + 1] = 0.0
        for k in range(1, R + 1):
            expect[a - D + R - k] = expect[b + H + k] = k / (R + 1)  # both ramps rise away from the talker
        np.testing.assert_allclose(held[D:], expect[:F - D], rtol=0, atol=1e-12)


def test_snr_share_clip_leaves_a_loud_frame_out_of_the_noise():
    """``frame_snr_clip_db = 15``: a quiet frame more than 15 dB over the noise's average (a talker the ratio
    missed) is not noise.  Closed form: talker frames at 100, quiet ones at 1 and one at 100 (20 dB up) -- the
    noise average stays 1 with 5 frames counted (share 1 from SNR 20 dB); without the clip it is 105 / 6
    (SNR 7.6 dB: share 0.26 on (6, 12))."""
    from enhancers.beam.mic_calibration import _frame_snr_share

    talker = np.array([True] * 3 + [False] * 6)
    power = np.array([100.0] * 3 + [1.0, 1.0, 1.0, 100.0, 1.0, 1.0])
    quiet = ~talker
    for clip, noise, count in ((15.0, 1.0, 5), (None, 105.0 / 6.0, 6)):
        p = make("mic-calibration", frame_q_db=5.0, frame_snr_db=(6.0, 12.0), frame_snr_clip_db=clip).params
        kappa, state = _frame_snr_share(talker, power, None, p, fs=FS, quiet=quiet, quiet_power=power)
        np.testing.assert_allclose(state[2:], [noise, count], rtol=1e-12)
        expect = min(1.0, max(0.0, (10 * np.log10(100.0 / noise) - 6.0) / 6.0))
        np.testing.assert_allclose(kappa[-1], expect, rtol=0, atol=1e-12)


def test_frame_rule_start_weights_stop_when_the_talker_is_first_heard():
    """The weights the DAS weight may learn at once (``mix_fast_cells``): the frame rule's own, frame by frame,
    from the stream start until it first weighs a frame below 1 -- the talker's first burst at 4 s (less the
    rule's lag) -- and 0 from there on, after the burst too (closed form of the rule: a stream starts on the
    noise, and after the talker was heard only the held, delayed weights are safe).  Streaming in blocks of
    7 frames gives the same (the ``heard`` flag is carried)."""
    from enhancers.beam.mic_calibration import _frame_weights, calibration_init

    rng = np.random.default_rng(7)
    n = 6 * FS
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    on = (np.arange(n) >= 4 * FS) & (np.arange(n) < int(4.5 * FS))
    talk = plane_wave_pair(rng.standard_normal(n), az_deg=45) * on * 3.0
    e = make("mic-calibration", **FRAME_RULE)
    X = e.filterbank.analyze(noise + talk)
    kw = dict(p=e.params, fs=FS, delay=e.delay_samples(FS), n_ahead=30)
    import dataclasses

    def run(blocks):
        state, nows = calibration_init(X.shape[2]), []
        for lo in range(0, X.shape[1], blocks):
            changes = {}
            _, _, now, _ = _frame_weights(X[0, lo:lo + blocks], X[1, lo:lo + blocks], state, changes=changes, **kw)
            state = dataclasses.replace(state, **changes)
            nows.append(now)
        return np.concatenate(nows)

    now = run(X.shape[1])
    t = np.arange(now.size) * 128 / FS
    assert now[t < 3.9].min() == 1.0 and now[t > 4.05].max() == 0.0
    np.testing.assert_array_equal(run(7), now)


@pytest.mark.parametrize("blocks", [None, 5])
def test_frame_start_frames_are_neither_learned_nor_heard(blocks):
    """``frame_start_s = 0.1`` (12 frames of 128 samples): a talker click in the stream's first 24 ms (10 dB over
    the diffuse noise; a real recording's start transient) is heard by the rule, which without the option
    ends the start-up weights at frame 0 and holds the frames of its hold (0.2 s) out of the averages.
    Closed form with the option (the click and the ~5 frames the rule's smoother, 0.7 per frame, keeps its
    ratio over 5 dB lie inside the 12 frames, whose decisions are not trusted): every frame up to the talker's
    burst at 4 s weighs 1 in the start-up weights and in the averages (held weights; inside ``eb-robust``
    too), and the SNR share has seen no talker frame (state ``snr``: no talker count); streaming in blocks
    of 5 frames gives the same."""
    import dataclasses

    from enhancers.beam.mic_calibration import _frame_weights, calibration_init

    rng = np.random.default_rng(8)
    n = 6 * FS
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    t = np.arange(n) / FS
    on = (t < 0.024) | ((t >= 4.0) & (t < 4.5))
    talk = plane_wave_pair(rng.standard_normal(n), az_deg=45) * on * np.sqrt(10.0)
    X = make("mic-calibration").filterbank.analyze(noise + talk)
    d = 30  # level_ahead_s 0.24 s

    def run(start_s, X=X):
        e = make("mic-calibration", **FRAME_RULE, frame_start_s=start_s, frame_snr_db=(6.0, 12.0))
        kw = dict(p=e.params, fs=FS, delay=e.delay_samples(FS), n_ahead=d)
        state, helds, nows, step = calibration_init(X.shape[2]), [], [], blocks or X.shape[1]
        for lo in range(0, X.shape[1], step):
            changes = {}
            held, _, now, _ = _frame_weights(X[0, lo:lo + step], X[1, lo:lo + step], state, changes=changes, **kw)
            state = dataclasses.replace(state, **changes, n_frames=state.n_frames + len(now))  # (as _masks_step)
            helds.append(held)
            nows.append(now)
        return np.concatenate(helds)[d:], np.concatenate(nows), state

    held0, now0, _ = run(0.0)
    held, now, state = run(0.1)
    tf = np.arange(now.size) * 128 / FS
    assert now0.max() == 0.0 and held0[:25].max() == 0.0  # the control: the click ends the start-up
    assert now[tf < 3.7].min() == 1.0 and held[tf[:held.size] < 3.7].min() == 1.0
    before = X[:, :int(3.5 * FS / 128)]  # state.snr[1]: the talker frames the share counted before the burst
    assert run(0.1, before)[2].snr[1] == 0.0 and run(0.0, before)[2].snr[1] > 0.0
    # the averages' weights inside eb-robust (rows D behind the frames)
    wts = _learn_weights(noise + talk, **FRAME_RULE, frame_start_s=0.1, frame_snr_db=(6.0, 12.0))
    assert wts[d:d + int(3.7 * FS / 128)].min() == 1.0


def _low_band_talker(rng, n):
    """White diffuse noise, ``(2, n)``, and a talker at 45 deg with power only in 300-900 Hz (brick-wall), 10 dB
    above the noise in that band, 2-2.5 s, ideal pair; and the burst's mask."""
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / FS)
    spec[(f < 300) | (f > 900)] = 0.0
    on = (np.arange(n) >= 2 * FS) & (np.arange(n) < int(2.5 * FS))
    talk = plane_wave_pair(np.fft.irfft(spec, n), az_deg=45) * on
    talk *= np.sqrt(10 * np.mean(noise[0] ** 2) * 600 / 8000 / np.mean(talk[0, on] ** 2))
    return noise, talk, on


@pytest.mark.parametrize("low_hz, heard", [(None, False), (250.0, True)])
def test_frame_rule_low_band_hears_a_low_talker(low_hz, heard):
    """``frame_low_hz``: the band below ``frame_band_hz`` is judged on its own, and the frame is the talker's if
    either band's ratio is over the threshold.  A talker with power only in 300-900 Hz, 10 dB over diffuse
    noise there (closed form for an ideal pair: the cardioid ratio of a 45 deg plane wave is ~15 dB at low
    frequencies, of a diffuse field 0 dB): with 250 Hz-1 kHz judged its frames (2.05-2.45 s) get weight 0;
    1-4 kHz alone holds only the noise there and learns them all.  Frames away from the burst: 1 either way."""
    noise, talk, _ = _low_band_talker(np.random.default_rng(8), 5 * FS)
    extra = {} if low_hz is None else {"frame_low_hz": low_hz}
    w = _frame_weights_of(noise + talk, level_hang_s=0.0, level_ahead_s=0.0, **extra)
    t = np.arange(w.size) * 128 / FS
    burst = (t > 2.05) & (t < 2.45)
    assert w[burst].max() == (0.0 if heard else 1.0)
    assert w[(t < 1.9) | (t > 2.6)][3:].min() == 1.0


@pytest.mark.parametrize("step_db, loud", [(12.0, False), (28.0, True)])
def test_frame_level_rule_fires_far_above_the_floor(step_db, loud):
    """``frame_level_db = 20``: diffuse noise (cardioid ratio 0 dB, so the ratio rule learns every frame) that
    steps up by 28 dB for 0.5 s is more than 20 dB over its running minimum (the noise floor): the frames of
    the step (2.05-2.45 s) get weight 0; a 12 dB step stays under it (the floor's minimum-statistics bias, a few
    dB, leaves > 5 dB of margin) and every frame is learned; before the step, after it, and at the stream start
    (whose partial first frame stays out of the floor) every frame is learned."""
    rng = np.random.default_rng(9)
    n = 5 * FS
    noise = diffuse_noise(n, SPACING_M, fs=FS, rng=rng)
    on = (np.arange(n) >= 2 * FS) & (np.arange(n) < int(2.5 * FS))
    w = _frame_weights_of(noise * np.where(on, 10 ** (step_db / 20), 1.0), frame_level_db=20.0,
                          level_hang_s=0.0, level_ahead_s=0.0)
    t = np.arange(w.size) * 128 / FS
    step = (t > 2.05) & (t < 2.45)
    assert w[step].max() == (0.0 if loud else 1.0)
    assert w[(t < 1.95) | (t > 2.6)].min() == 1.0


@pytest.mark.parametrize("bad", [{"frame_low_hz": 1000.0}, {"frame_low_hz": -5.0}, {"frame_level_db": 0.0},
                                 {"frame_snr_quiet": "yes"}, {"frame_start_s": -0.1},
                                 {"frame_snr_frames": -1.0}, {"frame_snr_quiet_ratio": 1},
                                 {"frame_snr_quiet_ratio": True},
                                 {"frame_snr_low_hz": 1000.0}, {"frame_snr_low_hz": -1.0},
                                 {"frame_snr_clip_db": 0.0}, {"frame_hold_taper_s": 0.3},  # > level_ahead_s
                                 {"frame_hold_taper_s": -0.01}, {"cal_rear_soft_db": 3.0},  # no cal_rear_db
                                 {"cal_rear_soft_db": -1.0, "cal_rear_db": 10.0},
                                 {"cal_rear_lam": 0.8, "cal_rear_db": 10.0},  # no cal_rear_soft_db
                                 {"cal_rear_lam": 1.0, "cal_rear_db": 10.0, "cal_rear_soft_db": 3.0}])
def test_frame_band_and_level_parameters_are_checked(bad):
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError):
        make("mic-calibration", frame_q_db=5.0, **bad)


@pytest.mark.parametrize("bad", [{"cal_rear_low_db": 6.0},  # no frame_snr_db: no share to follow
                                 {"cal_rear_low_db": 6.0, "frame_snr_db": (6.0, 12.0)},  # no cal_rear_db
                                 {"cal_rear_low_db": 12.0, "frame_snr_db": (6.0, 12.0), "cal_rear_db": 10.0},
                                 {"cal_rear_low_db": -1.0, "frame_snr_db": (6.0, 12.0), "cal_rear_db": 10.0}])
def test_rear_low_threshold_parameters_are_checked(bad):
    """One-line errors; the valid neighbour (low 6 <= 10 dB, with the share) is accepted."""
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError, match="cal_rear_low_db"):
        make("mic-calibration", frame_q_db=5.0, **bad)
    make("mic-calibration", frame_q_db=5.0, frame_snr_db=(6.0, 12.0), cal_rear_db=10.0, cal_rear_low_db=6.0)


def test_blocks_match_one_pass_with_the_frame_rules_low_band_and_level():
    """Streaming (blocks of 1, 6, 43 and 200 samples) == one pass with ``frame_low_hz``, ``frame_level_db`` and the
    SNR share on the held-quiet frames (the two bands' smoothers, the level's floor and the pending band powers
    are carried).  Oracle: the same computation, to 1e-12."""
    s, n = _talker_bursts(35)
    e = make("mic-calibration", **FRAME_RULE, frame_low_hz=250.0, frame_level_db=20.0, frame_snr_db=(6.0, 12.0),
             frame_snr_quiet=True)
    _assert_blocks_match_one_pass(e, s + n, [1, 6, 43, 200])


def test_frame_snr_share_on_quiet_frames_closed_form():
    """``frame_snr_quiet``: the noise's average runs over the frames given as quiet only.  Five talker frames
    (power 10), five the ratio missed (power 10, neither talker nor quiet) and five quiet ones (power 1):
    over every unmarked frame the estimate is 10 / 5.5 = 2.6 dB -> share 0; over the quiet ones 10 / 1 = 10 dB ->
    share (10 - 6) / (12 - 6) = 2/3 (closed form, to 1e-12)."""
    from enhancers.beam.mic_calibration import _frame_snr_share

    p = make("mic-calibration", frame_q_db=5.0, frame_snr_db=(6.0, 12.0)).params
    talker = np.array([True] * 5 + [False] * 10)
    power = np.array([10.0] * 10 + [1.0] * 5)
    quiet = np.array([False] * 10 + [True] * 5)
    kappa, _ = _frame_snr_share(talker, power, None, p, fs=FS)
    np.testing.assert_allclose(kappa[-1], 0.0, rtol=0, atol=1e-12)
    kappa, state = _frame_snr_share(talker, power, None, p, fs=FS, quiet=quiet, quiet_power=power)
    np.testing.assert_allclose(kappa[-1], 2.0 / 3.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state, [10.0, 5, 1.0, 5], rtol=0, atol=1e-12)


def _snr_noise_average(x, **params):
    """The input-SNR estimate's noise average (state ``snr[2]``) of the frame rule over ``x`` in one pass."""
    from enhancers.beam.mic_calibration import _frame_weights, calibration_init

    e = make("mic-calibration", **FRAME_RULE, frame_snr_db=(6.0, 12.0), **params)
    X = e.filterbank.analyze(x)
    changes = {}
    _frame_weights(X[0], X[1], calibration_init(X.shape[2]), e.params, fs=FS, delay=e.delay_samples(FS),
                   n_ahead=30, changes=changes)
    return changes["snr"][2]


def test_frame_snr_quiet_ratio_counts_a_machines_hits_as_noise():
    """``frame_snr_quiet_ratio``: the noise's frames are those away from the ratio rule's talker frames, so a
    machine's hits (here the diffuse noise 20 dB up for 0.1 s at 2.2, 4.2 and 5.2 s: cardioid ratio 0 dB, far
    over the level rule's 15 dB) count as noise.  Closed form: 0.3 s at 100x in 6 s raise the noise's mean power
    5.95x.  The level rule's quiet frames leave the hits out: within 2 % of the same estimate without the hits
    (measured 0.1 %); away from the ratio rule's talker frames they are in: at least 5x that (measured 8.7x:
    the one-pole average weighs the last hit more than an even mean would)."""
    s, n = _talker_bursts(38)
    t = np.arange(n.shape[1]) / FS
    hits = ((t >= 2.2) & (t < 2.3)) | ((t >= 4.2) & (t < 4.3)) | ((t >= 5.2) & (t < 5.3))
    level = dict(frame_level_db=15.0, frame_snr_quiet=True)
    no_hits = _snr_noise_average(s + n, **level)
    n = n * np.where(hits, 10.0, 1.0)
    with_level = _snr_noise_average(s + n, **level)
    with_ratio = _snr_noise_average(s + n, **level, frame_snr_quiet_ratio=True)
    assert abs(with_level / no_hits - 1.0) <= 0.02 and with_ratio / no_hits >= 5.0


def test_frame_snr_low_hz_widens_the_estimates_band():
    """``frame_snr_low_hz = 250``: the input-SNR estimate's powers run over 250 Hz-4 kHz (bins 4-64) instead of
    ``frame_band_hz`` (1-4 kHz, bins 16-64).  Closed form for white diffuse noise (a flat spectrum): the noise
    average grows by the bin count, 61 / 49, within 1 % (measured 0.08 %: the two bands share 49 of their bins,
    and the 12 more average ~375 frames)."""
    n = diffuse_noise(6 * FS, SPACING_M, fs=FS, rng=np.random.default_rng(39))
    ratio = (_snr_noise_average(n, frame_snr_quiet=True, frame_snr_low_hz=250.0)
             / _snr_noise_average(n, frame_snr_quiet=True))
    assert abs(ratio / (61 / 49) - 1.0) <= 0.01


def test_frame_snr_quiet_measures_the_noise_alone():
    """``frame_snr_quiet``: the input-SNR estimate's noise average over the frames the held rule leaves quiet (30
    frames behind, their band powers pending) is the noise's own: two talker bursts 20 dB over diffuse noise
    leave it within 2 % of the same estimate on the noise alone (measured 0.04 %; the two average different
    frames: a frame's band power over 49 bins spreads by ~14 %, over the one-pole's ~375 frames by ~0.7 %,
    so 2 % is about 3 of that).  Over every frame the ratio does not mark -- the bursts' quiet edges among them --
    it is >= 5 % high (measured 8 %)."""
    s, n = _talker_bursts(36)
    alone = _snr_noise_average(n)
    assert abs(_snr_noise_average(s + n, frame_snr_quiet=True) / alone - 1.0) <= 0.02
    assert _snr_noise_average(s + n) / alone >= 1.05
