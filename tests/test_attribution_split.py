"""The three-way SNR-I split and its 1/3-octave resolution rule (issue 32, part 6): oracles.

* Resolution: the rule's spectral SNR-I moves <= 0.15 dB when the Welch segment goes
  0.064 -> 0.128 -> 0.256 s on a comb filter (an echo) meeting harmonic noise, while the
  unsmoothed estimate moves >= 1 dB (measured 0.08 vs 2.47 dB; on real speech 0.1 vs 2.7).
* A fixed single-mic filter: spatial exactly 0 (the fixed filter uses one mic), time-varying 0
  within 0.1 dB (measured 0.03 dB on the harmonic stand-in speech).
* A fixed 2-mic filter (delay-and-subtract): time-varying 0 within 0.2 dB (measured 0.14 dB:
  its responses have 20 dB notches that 1/3-octave smoothing rounds), spatial = total - spectral.
* A time-varying single-channel gain (a speech gate, and ``ss``): spatial exactly 0; the gate's
  gain is flat in frequency, so spectral 0 (within 0.05 dB) and all of it time-varying.
* A switched 2-mic weight: the fixed filter is the joint fit to speech and noise at equal power,
  closed form for flat spectra.
* Black boxes: the rule's spectral column only; spatial and time-varying empty.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_evaluate import StandInScene, make_scene
from test_measures import FixedLowpass

from benchmarks.metrics.attribution_split import SPLIT_COLUMNS, sensitivity
from benchmarks.metrics.evaluate import evaluate_enhancer, input_metrics
from enhancers.core.base import Enhancer, Result, Tags

FS = 16000


@pytest.fixture(scope="module")
def scene():
    return make_scene(np.random.default_rng(32), seconds=4.0)


@pytest.fixture(scope="module")
def inputs(scene):
    return input_metrics(scene)


@pytest.fixture(scope="module")
def broadband():
    """Speech with power in every band (white noise, 4 Hz syllables) at broadside, white noise."""
    rng = np.random.default_rng(33)
    t = np.arange(4 * FS) / FS
    s = rng.standard_normal(t.size) * np.clip(np.sin(2 * np.pi * 4.0 * t), 0.0, None) ** 2
    speech, noise = np.stack([s, s]), 0.3 * rng.standard_normal((2, t.size))
    scene = StandInScene(mixture=speech + noise, speech_image=speech, noise_image=noise,
                         reference=s[None, :].copy(), fs=FS, snr_db=0.0)  # fmt: skip
    return scene, input_metrics(scene)


class TwoMicOp(Enhancer):
    """A replayable 2-mic linear operation ``op(c) -> (1, n)``, set per instance as ``toy.op``."""

    name = "test-two-mic-op"
    op = staticmethod(lambda c: c[:1])

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=2)

    def _process(self, x, fs):
        def replay(c):
            return np.asarray(self.op(np.asarray(c, dtype=float)), dtype=float).reshape(1, -1)

        return Result(output=replay(x), _replay=replay)


def _toy(op) -> TwoMicOp:
    toy = TwoMicOp()
    toy.op = op
    return toy


def _delay_subtract(c):
    """``y = x0 - 0.9 x1[n - 1]``: a fixed 2-mic filter."""
    return c[0] - 0.9 * np.concatenate([[0.0], c[1][:-1]])


def _split(row):
    return [row[k] for k in SPLIT_COLUMNS]


def test_rule_is_insensitive_to_the_welch_segment_where_the_unsmoothed_estimate_is_not():
    values = sensitivity(seed=0)
    assert np.ptp(values["rule"]) <= 0.15
    assert np.ptp(values["unsmoothed"]) >= 1.0 and np.ptp(values["fir"]) >= 1.0


def test_rule_on_real_speech(shared_data_dir):
    import soundfile as sf

    x, fs = sf.read(shared_data_dir / "speech" / "cmu_arctic_a0009.wav")
    assert fs == FS
    values = sensitivity(seed=0, speech=np.asarray(x, dtype=float))
    assert np.ptp(values["rule"]) <= 0.15
    assert np.ptp(values["unsmoothed"]) >= 1.0


def test_single_mic_fixed_filter_is_all_spectral(scene, inputs):
    row = evaluate_enhancer(FixedLowpass(), scene, input_metrics=inputs)
    spectral, spatial, varying = _split(row)
    assert abs(row["snr_i_db"]) > 1.0
    assert spatial == pytest.approx(0.0, abs=1e-9)
    assert varying == pytest.approx(0.0, abs=0.1)
    assert spectral + spatial + varying == pytest.approx(row["snr_i_db"], abs=1e-9)


def test_fixed_two_mic_filter_has_no_time_varying_part(scene, inputs):
    row = evaluate_enhancer(_toy(_delay_subtract), scene, input_metrics=inputs)
    spectral, spatial, varying = _split(row)
    assert abs(spatial) > 0.5  # the noise (3-sample lag) and speech (1 sample) are filtered differently
    assert varying == pytest.approx(0.0, abs=0.2)
    assert spatial == pytest.approx(row["snr_i_db"] - spectral, abs=0.2)


def test_time_varying_gain_on_one_mic_is_time_varying(broadband):
    scene, inputs = broadband
    env = np.abs(scene.speech_image[0])
    smooth = np.convolve(env, np.ones(400) / 400, mode="same")
    gate = np.where(smooth > 0.5 * smooth.mean(), 1.0, 0.1)  # on mic 0 only
    row = evaluate_enhancer(_toy(lambda c: gate * c[0]), scene, input_metrics=inputs)
    spectral, spatial, varying = _split(row)
    assert row["snr_i_db"] > 2.0
    assert spatial == pytest.approx(0.0, abs=1e-9)  # mic 1 replayed alone gives 0: W_1 = 0
    assert spectral == pytest.approx(0.0, abs=0.05)  # a gain flat in frequency shapes nothing
    assert varying == pytest.approx(row["snr_i_db"], abs=0.05)


def test_fixed_filter_of_a_switched_weight_is_the_joint_equal_power_fit(broadband):
    # Oracle: speech equal at both mics, noise white and independent, both flat in frequency, so
    # per bin the fit is W = [1, -beta], beta = (b_s + b_n) / 2 (the speech- and the
    # noise-power-weighted means of b), whose SNR gain is D = (1 - beta)^2 / (1 + beta^2) in
    # every bin; the speech response is flat, so spatial = 10 lg D.  0.05 dB: the fit's
    # estimate per bin (measured 0.004 dB).
    scene, inputs = broadband
    s, n = scene.speech_image[0], scene.noise_image
    b = np.where(np.arange(s.size) % 4000 < 1000, 0.8, 0.0)  # y = x0 - b(t) x1
    row = evaluate_enhancer(_toy(lambda c: c[0] - b * c[1]), scene, input_metrics=inputs)
    beta = (np.sum(b * s**2) / np.sum(s**2) + np.sum(b * n[1] ** 2) / np.sum(n[1] ** 2)) / 2
    assert row["snr_i_fixed_spatial_db"] == pytest.approx(10 * np.log10((1 - beta) ** 2 / (1 + beta**2)), abs=0.05)


def test_spectral_subtraction_has_no_spatial_part(broadband):
    from enhancers.core.registry import make

    scene, inputs = broadband
    row = evaluate_enhancer(make("ss"), scene, input_metrics=inputs)
    spectral, spatial, varying = _split(row)
    assert spatial == pytest.approx(0.0, abs=1e-9)  # one channel in: nothing spatial to fit
    assert varying > 0.5 * row["snr_i_db"] > 0.0


def test_black_boxes_get_the_rule_but_no_split(scene, inputs):
    from test_evaluate import DelayedLowpassRamp

    row = evaluate_enhancer(DelayedLowpassRamp(replayable=False), scene, input_metrics=inputs)
    assert row["snr_method"] == "phase-inversion"
    assert row["snr_i_fixed_spectral_db"] is not None
    assert row["snr_i_fixed_spatial_db"] is None and row["snr_i_time_varying_db"] is None
