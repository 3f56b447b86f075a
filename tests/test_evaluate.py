"""Per-condition evaluation with a stand-in scene and small linear test enhancers."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pytest
from scipy.signal import lfilter

from benchmarks.metrics.evaluate import INPUT_COLUMNS, ROW_COLUMNS, evaluate_enhancer, input_metrics
from enhancers.core.base import Enhancer, Params, Result, Tags
from scenesim.validate import check_finite_number, check_int

FS = 16000


@dataclass(frozen=True)
class StandInScene:
    """Same fields as ``scenesim.scene.compose.RenderedScene`` (what evaluate needs)."""

    mixture: np.ndarray
    speech_image: np.ndarray
    noise_image: np.ndarray
    reference: np.ndarray
    fs: int
    snr_db: float
    scene: Any = None


def _speech_like(rng, seconds=2.0, fs=FS):
    """Harmonic complex (150 Hz) with 4 Hz syllabic modulation: PESQ/STOI find utterances."""
    t = np.arange(int(seconds * fs)) / fs
    voiced = sum(np.sin(2 * np.pi * 150 * k * t) / k for k in range(1, 20))
    envelope = np.clip(np.sin(2 * np.pi * 4 * t), 0, None) ** 2
    return 0.1 * envelope * voiced


def make_scene(rng, *, snr_db=5.0, silent_speech=False, seconds=2.0) -> StandInScene:
    """Two mics: channel 1 is channel 0 delayed by 1 sample (speech) / 3 samples (noise)."""
    s = np.zeros(int(seconds * FS)) if silent_speech else _speech_like(rng, seconds)
    n = rng.standard_normal(s.size + 3)
    # Scaled on the samples channel 0 gets, against the (non-silent) speech power.
    ref_power = np.mean(_speech_like(rng, seconds) ** 2)
    n *= np.sqrt(ref_power / np.mean(n[3:] ** 2) / 10 ** (snr_db / 10))
    speech = np.stack([s, np.concatenate([[0.0], s[:-1]])])
    noise = np.stack([n[3:], n[:-3]])
    return StandInScene(
        mixture=speech + noise,
        speech_image=speech,
        noise_image=noise,
        reference=s[None, :].copy(),
        fs=FS,
        snr_db=snr_db,
    )


# -- test enhancers ------------------------------------------------------------------------


@dataclass(frozen=True)
class GainParams(Params):
    gain: float = 0.5

    def __post_init__(self):
        check_finite_number("gain", self.gain)


class FixedGain(Enhancer):
    """``y = gain * x`` on the reference mic: linear and time invariant."""

    name = "test-gain"
    Params = GainParams

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1)

    def _process(self, x, fs):
        g = self.params.gain
        return Result(output=g * x, _replay=lambda c: g * np.asarray(c, dtype=float))


class FrontMicOnly(Enhancer):
    """Two channels in; zeroes channel 1 and passes channel 0 (passthrough-like)."""

    name = "test-front"

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=2)

    def _process(self, x, fs):
        weights = np.array([1.0, 0.0])
        return Result(output=weights @ x[None], _replay=lambda c: (weights @ np.asarray(c))[None])


@dataclass(frozen=True)
class FirParams(Params):
    delay: int = 0
    declared: int = 0
    replayable: bool = True

    def __post_init__(self):
        check_int("delay", self.delay, minimum=0)
        check_int("declared", self.declared, minimum=0)


class DelayedLowpassRamp(Enhancer):
    """Time-varying but linear: 2-mic sum, FIR low-pass, a gain ramp, then a pure delay.

    ``params.declared`` is the latency it *declares*; ``params.delay`` the one it applies.
    The trace holds a per-sample 'beta' (the ramp) so trace_json can be checked.
    """

    name = "test-fir"
    Params = FirParams
    taps: ClassVar[np.ndarray] = np.hanning(9) / np.hanning(9).sum()

    @property
    def tags(self) -> Tags:
        return Tags(
            channels_in=2,
            latency_samples=self.params.declared,
            replayable=self.params.replayable,
        )

    def _op(self, c):
        c = np.asarray(c, dtype=float)
        y = lfilter(self.taps, [1.0], c[0] + 0.5 * c[1])
        y *= np.linspace(0.5, 1.5, y.size)
        d = self.params.delay
        return np.concatenate([np.zeros(d), y[: y.size - d]])[None]

    def _process(self, x, fs):
        ramp = np.linspace(0.5, 1.5, x.shape[1])
        replay = self._op if self.params.replayable else None
        return Result(output=self._op(x), trace={"beta": ramp, "gain": ramp[:10]}, _replay=replay)


class Broken(Enhancer):
    name = "test-broken"

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1)

    def _process(self, x, fs):
        raise RuntimeError("deliberate failure")


class ThreeChannels(FixedGain):
    name = "test-three"

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=3)


# -- tests ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scene():
    return make_scene(np.random.default_rng(7))


@pytest.fixture(scope="module")
def scene_inputs(scene):
    return input_metrics(scene)


def test_input_metrics_columns_and_measured_snr(scene, scene_inputs):
    assert set(scene_inputs) == set(INPUT_COLUMNS)
    assert scene_inputs["input_error"] is None
    # Oracle: the noise was scaled to 5 dB against a speech signal with the same power.
    np.testing.assert_allclose(scene_inputs["snr_in_db_measured"], 5.0, atol=1e-9)
    for key in ("pesq_nb_in", "pesq_wb_in", "stoi_in", "estoi_in", "segsnr_in_db"):
        assert np.isfinite(scene_inputs[key])


def test_fixed_gain_has_zero_snr_improvement(scene, scene_inputs):
    # Oracle: a linear gain scales speech and noise alike, so SNR-I = 0 (to 1e-9).
    row = evaluate_enhancer(FixedGain(gain=0.3), scene, input_metrics=scene_inputs)
    assert row["status"] == "ok" and row["error"] is None, row["error"]
    assert row["snr_method"] == "replay"
    np.testing.assert_allclose(row["snr_i_db"], 0.0, atol=1e-9)
    np.testing.assert_allclose(row["snr_out_db"], scene_inputs["snr_in_db_measured"], atol=1e-9)
    # PESQ normalises level, STOI and SI-SDR are scale invariant: no change either.
    np.testing.assert_allclose(row["pesq_nb_i"], 0.0, atol=1e-3)
    np.testing.assert_allclose(row["stoi_i"], 0.0, atol=1e-9)
    np.testing.assert_allclose(row["si_sdr_i_db"], 0.0, atol=1e-9)
    assert row["latency_check"] is None and row["latency_est_samples"] == 0
    assert set(row) == set(ROW_COLUMNS)


def test_front_mic_passthrough_has_zero_snr_improvement(scene, scene_inputs):
    # Oracle: the output is exactly the reference mic, whose SNR is the input SNR.
    row = evaluate_enhancer(FrontMicOnly(), scene, input_metrics=scene_inputs)
    assert row["status"] == "ok", row["error"]
    np.testing.assert_allclose(row["snr_i_db"], 0.0, atol=1e-9)
    np.testing.assert_allclose(row["pesq_wb_out"], row["pesq_wb_in"], atol=1e-12)


def test_unchanged_output_reuses_the_input_scores_without_scoring_again(scene, scene_inputs, monkeypatch):
    # Oracle: identical signals get identical scores; the scorer is not called for them.
    import benchmarks.metrics.speech as M

    calls = []
    real = M.pesq_scores
    monkeypatch.setattr(M, "pesq_scores", lambda *a, **k: calls.append(1) or real(*a, **k))
    row = evaluate_enhancer(FrontMicOnly(), scene, input_metrics=scene_inputs)
    assert calls == []
    for name in ("pesq_nb", "pesq_wb", "stoi", "estoi"):
        assert row[f"{name}_out"] == scene_inputs[f"{name}_in"]
    # Any change to the signal (here a gain of 0.999) is scored afresh.
    evaluate_enhancer(FixedGain(gain=0.999), scene, input_metrics=scene_inputs)
    assert calls == [1]


def test_phase_inversion_equals_replay_for_a_linear_enhancer(scene, scene_inputs):
    # Oracle: Hagerman & Olofsson -- for any linear operator f, (f(s+n) +- f(s-n))/2 = f(s), f(n).
    replay = evaluate_enhancer(DelayedLowpassRamp(), scene, input_metrics=scene_inputs)
    black = evaluate_enhancer(
        DelayedLowpassRamp(replayable=False), scene, input_metrics=scene_inputs
    )
    assert (replay["snr_method"], black["snr_method"]) == ("replay", "phase-inversion")
    assert abs(replay["snr_i_db"]) > 0.5  # the low-pass really changes the SNR
    np.testing.assert_allclose(black["snr_out_db"], replay["snr_out_db"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(black["snr_i_db"], replay["snr_i_db"], rtol=0, atol=1e-9)


def test_declared_latency_is_undone_and_checked(scene, scene_inputs):
    # Declared == applied delay: aligned metrics equal the undelayed ones, no warning.
    undelayed = evaluate_enhancer(DelayedLowpassRamp(), scene, input_metrics=scene_inputs)
    delayed = evaluate_enhancer(
        DelayedLowpassRamp(delay=64, declared=64), scene, input_metrics=scene_inputs
    )
    # The 9-tap low-pass adds its own 4-sample group delay on top of the pure delay.
    assert undelayed["latency_est_samples"] == 4 and undelayed["latency_check"] is None
    assert delayed["latency_check"] is None and delayed["latency_est_samples"] == 64 + 4
    np.testing.assert_allclose(delayed["stoi_out"], undelayed["stoi_out"], atol=0.02)
    # Undeclared delay: the row carries a warning, not an exception.
    wrong = evaluate_enhancer(
        DelayedLowpassRamp(delay=64, declared=0), scene, input_metrics=scene_inputs
    )
    assert wrong["status"] == "ok"
    assert "lag of 68 samples" in wrong["latency_check"]


def test_trace_json_holds_a_decimated_beta_trajectory(scene, scene_inputs):
    row = evaluate_enhancer(DelayedLowpassRamp(), scene, input_metrics=scene_inputs)
    trace = json.loads(row["trace_json"])
    assert list(trace) == ["beta"]  # 'gain' is not a beta trace
    values = trace["beta"]["values"]
    assert 1000 <= len(values) <= 2000
    np.testing.assert_allclose([values[0], values[-1]], [0.5, 1.5], atol=1e-3)
    np.testing.assert_allclose(trace["beta"]["step_s"] * len(values), 2.0, rtol=1e-3)


def test_failing_enhancer_gives_an_error_row(scene, scene_inputs):
    row = evaluate_enhancer(Broken(), scene, input_metrics=scene_inputs)
    assert row["status"] == "error"
    assert "RuntimeError: deliberate failure" in row["error"]
    assert row["snr_out_db"] is None and row["pesq_nb_out"] is None
    assert row["pesq_nb_in"] == scene_inputs["pesq_nb_in"]  # inputs are still recorded


def test_too_many_input_channels_gives_an_error_row(scene, scene_inputs):
    row = evaluate_enhancer(ThreeChannels(), scene, input_metrics=scene_inputs)
    assert row["status"] == "error" and "channels_in" in row["error"]


def test_pesq_failure_on_silent_speech_is_recorded_not_raised():
    quiet = make_scene(np.random.default_rng(3), silent_speech=True)
    inputs = input_metrics(quiet)
    assert inputs["pesq_nb_in"] is None and "pesq_in" in inputs["input_error"]
    row = evaluate_enhancer(FixedGain(), quiet, input_metrics=inputs)
    assert row["status"] == "ok"
    assert row["pesq_nb_out"] is None and row["pesq_wb_out"] is None
    assert "pesq_out: PESQ: the reference signal is silent" in row["error"]
    assert "pesq_in" in row["error"]
    assert row["snr_out_db"] is not None and np.isfinite(row["snr_out_db"])


def test_input_metrics_are_computed_when_not_given(scene, scene_inputs):
    row = evaluate_enhancer(FixedGain(), scene)
    assert row["pesq_wb_in"] == scene_inputs["pesq_wb_in"]


def test_real_scene_and_builtin_enhancers_give_complete_rows():
    """The real scene layer and registry: every row complete, no latency warning.

    Oracles: passthrough is channel 0, so SNR-I = 0 (1e-9); a broadside (270 deg) point
    noise is nulled by the dipole that the EB adapts to (algorithms.md section 5: exact at
    every frequency when d = c/fs), so its SNR-I is large -- bound 10 dB (thesis: 12.7-20.5).
    """
    from enhancers.core.registry import make, with_geometry
    from scenesim.scene.compose import Scene, render_images

    scene = Scene(snr_db=5.0)  # speech 45 deg, one point noise at 270 deg, anechoic
    rendered = render_images(scene, _speech_like(None, seconds=3.0), [None]).mix(5.0)
    inputs = input_metrics(rendered)
    assert inputs["input_error"] is None
    np.testing.assert_allclose(inputs["snr_in_db_measured"], 5.0, atol=1e-9)
    rows = {}
    for name in ("passthrough", "eb", "ss", "eb-ss"):
        enhancer = with_geometry(make(name), spacing_m=scene.pair.spacing_m, c_mps=343.0)
        rows[name] = row = evaluate_enhancer(enhancer, rendered, input_metrics=inputs)
        assert row["status"] == "ok" and row["error"] is None, (name, row["error"])
        assert row["snr_method"] == "replay" and row["latency_check"] is None, name
        assert all(row[k] is not None for k in ("pesq_nb_out", "pesq_wb_out", "stoi_out")), name
    np.testing.assert_allclose(rows["passthrough"]["snr_i_db"], 0.0, atol=1e-9)
    assert rows["eb"]["snr_i_db"] > 10.0
    assert list(json.loads(rows["eb"]["trace_json"])) == ["beta"]
    assert list(json.loads(rows["eb-ss"]["trace_json"])) == ["eb.beta"]


def test_correlated_output_components_are_flagged(scene):
    # Oracle: with noise = -0.5 speech, 2<s, n> / P(s + n) = -1 / 0.25 = -4 exactly, for
    # any gain; such an SNR describes the components, not the output, hence the warning.
    s = scene.speech_image
    bad = StandInScene(s + (-0.5 * s), s, -0.5 * s, scene.reference, FS, 6.02)
    with pytest.warns(RuntimeWarning, match="snr_out_db is unreliable"):
        row = evaluate_enhancer(FixedGain(gain=2.0), bad)
    np.testing.assert_allclose(row["snr_cross_ratio"], -4.0, rtol=1e-12)
    assert row["status"] == "ok"


def test_hagerman_column_equals_replay_for_linear_and_differs_for_nonlinear(scene, scene_inputs):
    # Oracle: for a linear operator phase inversion recovers f(s), f(n) exactly (1e-9 dB);
    # SS's gain mask depends on its input, so f(s - n) uses another mask than f(s + n).
    import enhancers

    linear = evaluate_enhancer(DelayedLowpassRamp(), scene, input_metrics=scene_inputs)
    np.testing.assert_allclose(linear["snr_i_hagerman_db"], linear["snr_i_db"], atol=1e-9)
    black = evaluate_enhancer(DelayedLowpassRamp(replayable=False), scene, input_metrics=scene_inputs)
    assert black["snr_i_hagerman_db"] == black["snr_i_db"]  # its only SNR is by inversion
    ss = evaluate_enhancer(enhancers.make("ss"), scene, input_metrics=scene_inputs)
    assert ss["snr_method"] == "replay"
    assert abs(ss["snr_i_hagerman_db"] - ss["snr_i_db"]) > 0.05


def test_in_band_snr_columns(scene, scene_inputs):
    # Oracle: powers of the ideal band-pass by Parseval, computed here independently.
    from benchmarks.metrics.evaluate import INBAND_HZ

    s0, n0 = np.asarray(scene.speech_image)[0], np.asarray(scene.noise_image)[0]
    f = np.fft.rfftfreq(s0.size, 1 / scene.fs)
    sel = (f >= INBAND_HZ[0]) & (f <= INBAND_HZ[1])
    expected = 10 * np.log10(np.sum(np.abs(np.fft.rfft(s0)[sel]) ** 2) / np.sum(np.abs(np.fft.rfft(n0)[sel]) ** 2))
    assert scene_inputs["snr_in_band_db"] == pytest.approx(expected, abs=1e-6)
    assert (scene_inputs["inband_lo_hz"], scene_inputs["inband_hi_hz"]) == INBAND_HZ
    row = evaluate_enhancer(FixedGain(), scene, input_metrics=scene_inputs)
    assert row["snr_i_band_db"] == pytest.approx(0.0, abs=1e-9)  # a gain changes no SNR


def test_raw_pesq_columns_invert_the_p862_1_mapping(scene, scene_inputs):
    # Oracle: P.862.1, MOS-LQO = 0.999 + 4 / (1 + exp(-1.4945 x + 4.6607)) of the raw x.
    y = scene_inputs["pesq_nb_in"]
    x = scene_inputs["pesq_nb_raw_in"]
    np.testing.assert_allclose(0.999 + 4 / (1 + np.exp(-1.4945 * x + 4.6607)), y, rtol=1e-12)


def _band_power_db(s, n, fs, band):
    # Oracle: powers of the ideal band-pass by Parseval (both edges included), on the frequency
    # grid band_snr_db documents (the FFT zero-padded to scipy's next fast length).
    from scipy.fft import next_fast_len

    nfft = next_fast_len(s.size, real=True)
    f = np.fft.rfftfreq(nfft, 1 / fs)
    sel = (f >= band[0]) & (f <= band[1])
    ps, pn = (np.sum(np.abs(np.fft.rfft(x, nfft)[sel]) ** 2) for x in (s, n))
    return 10 * np.log10(ps / pn)


def test_in_band_snr_uses_the_scenes_band_and_undoes_the_latency(scene, scene_inputs):
    # A non-default band (500-2000 Hz) and a declared latency of 5 samples: the output's parts
    # are the replayed operation on each image, shifted back by 5 (closed form, tolerance 1e-6 dB).
    from types import SimpleNamespace

    banded = StandInScene(**{**scene.__dict__, "scene": SimpleNamespace(snr_band_hz=(500.0, 2000.0))})
    enh = DelayedLowpassRamp(DelayedLowpassRamp.Params(delay=5, declared=5))
    row = evaluate_enhancer(enh, banded, input_metrics=input_metrics(banded))
    assert (row["inband_lo_hz"], row["inband_hi_hz"]) == (500.0, 2000.0)
    s_out = enh._op(np.asarray(scene.speech_image))[0][5:]
    n_out = enh._op(np.asarray(scene.noise_image))[0][5:]
    want_out = _band_power_db(s_out, n_out, FS, (500.0, 2000.0))
    m = s_out.size
    s0, n0 = np.asarray(scene.speech_image)[0][:m], np.asarray(scene.noise_image)[0][:m]
    assert row["snr_out_band_db"] == pytest.approx(want_out, abs=1e-6)
    assert row["snr_i_band_db"] == pytest.approx(want_out - _band_power_db(s0, n0, FS, (500.0, 2000.0)), abs=1e-6)


@pytest.mark.parametrize(("fs", "top"), [(8000, 3500.0), (16000, 7000.0), (48000, 7000.0)])
def test_default_in_band_top_edge_is_capped_at_seven_sixteenths_of_fs(fs, top):
    # Closed form: min(7000, 7 fs / 16): 3.5 kHz at 8 kHz, the default 7 kHz from 16 kHz up.
    from types import SimpleNamespace

    from benchmarks.metrics.evaluate import inband_hz

    assert inband_hz(SimpleNamespace(scene=None, fs=fs)) == (100.0, top)
