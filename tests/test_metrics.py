"""Metric functions: oracles are the ``pesq`` package's stated values, closed forms and constructions."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from benchmarks.metrics.speech import (
    align,
    estimate_lag,
    pesq_scores,
    segmental_snr_db,
    si_sdr_db,
    snr_db,
    stoi_scores,
)
from scenesim.errors import MetricError, ParameterError

FS = 16000


def _speech_like(rng, seconds=2.0, fs=FS):
    """Harmonic complex (150 Hz) with 4 Hz syllabic on/off modulation plus a little noise."""
    t = np.arange(int(seconds * fs)) / fs
    voiced = sum(np.sin(2 * np.pi * 150 * k * t) / k for k in range(1, 20))
    envelope = np.clip(np.sin(2 * np.pi * 4 * t), 0, None) ** 2
    return 0.1 * envelope * voiced + 1e-4 * rng.standard_normal(t.size)


# -- PESQ / STOI ---------------------------------------------------------------------------


def test_pesq_reference_pair_matches_pesq_package_stated_values(shared_data_dir):
    # Oracle: the pesq package README/tests: wb 1.0832337141036987, nb 1.6072081327438354.
    ref, fs = sf.read(shared_data_dir / "pesq_reference" / "speech.wav")
    deg, fs_deg = sf.read(shared_data_dir / "pesq_reference" / "speech_bab_0dB.wav")
    assert fs == fs_deg == 16000
    scores = pesq_scores(ref, deg, fs=fs)
    np.testing.assert_allclose(scores["wb"], 1.0832337141036987, rtol=0, atol=1e-9)
    np.testing.assert_allclose(scores["nb"], 1.6072081327438354, rtol=0, atol=1e-9)


def test_pesq_resamples_other_rates_and_has_no_wideband_below_16k(rng):
    # Oracle: identical signals score near the top of the MOS-LQO scale (> 4.0) in any mode.
    x = _speech_like(rng)
    from scipy.signal import resample_poly

    at8k = pesq_scores(resample_poly(x, 1, 2), resample_poly(x, 1, 2), fs=8000)
    assert at8k["wb"] is None and at8k["nb"] > 4.0
    at48k = pesq_scores(resample_poly(x, 3, 1), resample_poly(x, 3, 1), fs=48000)
    assert at48k["wb"] > 4.0 and at48k["nb"] > 4.0


def test_pesq_on_silence_raises_metric_error(rng):
    x = _speech_like(rng)
    with pytest.raises(MetricError, match="silent"):
        pesq_scores(x, np.zeros_like(x), fs=FS)
    with pytest.raises(MetricError, match="silent"):
        pesq_scores(np.zeros_like(x), x, fs=FS)


def test_pesq_package_errors_become_metric_errors_with_the_reason(rng, monkeypatch):
    # pesq raises NoUtterancesError (message as bytes) when its VAD finds no speech; only
    # all-zero input triggers it reliably, which the silence check catches first, so the
    # package call is replaced by one that raises exactly what pesq raises.
    import pesq

    def no_utterances(*args, **kwargs):
        raise pesq.NoUtterancesError(b"No utterances detected")

    monkeypatch.setattr(pesq, "pesq", no_utterances)
    x = _speech_like(rng)
    with pytest.raises(MetricError, match="NoUtterancesError: No utterances detected"):
        pesq_scores(x, x, fs=FS)


def test_pesq_too_short_raises_metric_error(rng):
    x = _speech_like(rng, seconds=0.2)
    with pytest.raises(MetricError, match="0.25 s"):
        pesq_scores(x, x, fs=FS)


def test_pesq_rejects_mismatched_lengths(rng):
    x = _speech_like(rng)
    with pytest.raises(ParameterError, match="degraded"):
        pesq_scores(x, x[:-1], fs=FS)


def test_stoi_identical_is_one_and_short_input_raises(rng):
    # Oracle: STOI/ESTOI of a signal with itself is 1 (correlation of identical envelopes).
    x = _speech_like(rng)
    scores = stoi_scores(x, x, fs=FS)
    np.testing.assert_allclose([scores["stoi"], scores["estoi"]], 1.0, atol=1e-6)
    with pytest.raises(MetricError, match="too little active speech"):
        stoi_scores(x[:2000], x[:2000], fs=FS)
    with pytest.raises(MetricError, match="silent"):
        stoi_scores(np.zeros_like(x), x, fs=FS)


# -- energy ratios -------------------------------------------------------------------------


def test_snr_of_a_constructed_mixture_equals_target(rng):
    # Oracle: construction -- the noise is scaled to the target power ratio exactly.
    s = rng.standard_normal(8000)
    n = rng.standard_normal(8000)
    target = 7.3
    n *= np.sqrt(np.mean(s**2) / np.mean(n**2) / 10 ** (target / 10))
    np.testing.assert_allclose(snr_db(s, n), target, rtol=0, atol=1e-9)
    # Multichannel arrays pool all samples.
    np.testing.assert_allclose(snr_db(np.stack([s, s]), np.stack([n, n])), target, atol=1e-9)


def test_snr_is_finite_on_silence():
    assert np.isfinite(snr_db(np.zeros(10), np.zeros(10)))
    assert snr_db(np.ones(10), np.zeros(10)) > 250


def test_snr_rejects_shape_mismatch():
    with pytest.raises(ParameterError, match="noise"):
        snr_db(np.ones(10), np.ones(9))


def test_si_sdr_is_scale_invariant(rng):
    # Oracle: definition (Le Roux 2019) -- alpha absorbs any gain of the estimate.
    s = rng.standard_normal(4000)
    y = s + 0.3 * rng.standard_normal(4000)
    base = si_sdr_db(s, y)
    for gain in (0.01, 3.0, -2.0):
        np.testing.assert_allclose(si_sdr_db(s, gain * y), base, rtol=0, atol=1e-9)
        np.testing.assert_allclose(si_sdr_db(gain * s, y), base, rtol=0, atol=1e-9)


def test_si_sdr_of_signal_plus_orthogonal_noise_is_the_power_ratio(rng):
    # Oracle: with <s, n> = 0 and zero means, alpha = 1 and SI-SDR = 10 log10(|s|^2/|n|^2).
    s = rng.standard_normal(4000)
    s -= s.mean()
    n = rng.standard_normal(4000)
    n -= n.mean()
    n -= np.dot(n, s) / np.dot(s, s) * s
    n *= np.sqrt(np.dot(s, s) / np.dot(n, n) / 10 ** (12.5 / 10))
    np.testing.assert_allclose(si_sdr_db(s, s + n), 12.5, rtol=0, atol=1e-9)
    # A DC offset does not change it (zero-mean definition).
    np.testing.assert_allclose(si_sdr_db(s + 5.0, s + n - 2.0), 12.5, rtol=0, atol=1e-9)


def test_segmental_snr_clamps_each_frame(rng):
    # Oracle: closed forms per frame -- perfect frames clamp to 35 dB, an estimate of
    # -10 s has error 11 s (-20.8 dB, clamped to -10), zero output gives exactly 0 dB.
    frame = int(0.02 * FS)
    s = rng.standard_normal(10 * frame)
    np.testing.assert_allclose(segmental_snr_db(s, s, fs=FS), 35.0, atol=1e-12)
    np.testing.assert_allclose(segmental_snr_db(s, -10 * s, fs=FS), -10.0, atol=1e-12)
    np.testing.assert_allclose(segmental_snr_db(s, np.zeros_like(s), fs=FS), 0.0, atol=1e-12)
    half = s.copy()
    half[5 * frame :] *= -10  # five perfect frames, five clamped at -10 dB
    np.testing.assert_allclose(segmental_snr_db(s, half, fs=FS), 12.5, atol=1e-12)
    # e = s - 0.5 s: every frame is 10 log10(4) = 6.0206 dB, inside the clamp.
    np.testing.assert_allclose(
        segmental_snr_db(s, 0.5 * s, fs=FS), 10 * np.log10(4.0), rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        segmental_snr_db(s, 0.5 * s, fs=FS, clamp=(-10, 3)), 3.0, rtol=0, atol=1e-12
    )


def test_segmental_snr_bad_arguments(rng):
    s = rng.standard_normal(1000)
    with pytest.raises(ParameterError, match="frame_s"):
        segmental_snr_db(s, s, fs=FS, frame_s=0)
    with pytest.raises(ParameterError, match="clamp"):
        segmental_snr_db(s, s, fs=FS, clamp=(5, -5))
    with pytest.raises(ParameterError, match="estimate"):
        segmental_snr_db(s, s[:-3], fs=FS)
    with pytest.raises(MetricError, match="frame"):
        segmental_snr_db(s[:100], s[:100], fs=FS)


# -- alignment -----------------------------------------------------------------------------


@pytest.mark.parametrize("delay", [0, 1, 37, 250])
def test_estimate_lag_and_align_recover_a_known_delay(rng, delay):
    # Oracle: construction -- output is the reference delayed by `delay` samples.
    ref = rng.standard_normal(6000)
    out = np.concatenate([np.zeros(delay), ref])[: ref.size]
    assert estimate_lag(out, ref, max_lag=300) == delay
    assert estimate_lag(-out, ref, max_lag=300) == delay  # polarity does not matter
    assert estimate_lag(ref, out, max_lag=300) == -delay
    out_al, ref_al = align(out, ref, latency_samples=delay)
    assert out_al.shape == ref_al.shape == (ref.size - delay,)
    np.testing.assert_array_equal(out_al, ref_al)


def test_align_keeps_channels_and_rejects_too_long_latency(rng):
    ref = rng.standard_normal((1, 100))
    out = np.concatenate([np.zeros((2, 3)), np.repeat(ref, 2, axis=0)], axis=1)
    out_al, ref_al = align(out, ref, latency_samples=3)
    assert out_al.shape == (2, 100) and ref_al.shape == (1, 100)
    np.testing.assert_array_equal(out_al[1], ref_al[0])
    with pytest.raises(ParameterError, match="latency_samples"):
        align(out, ref, latency_samples=103)
    with pytest.raises(ParameterError, match="latency_samples"):
        align(out, ref, latency_samples=-1)


def test_estimate_lag_limits_the_search(rng):
    ref = rng.standard_normal(2000)
    out = np.concatenate([np.zeros(50), ref])[: ref.size]
    assert abs(estimate_lag(out, ref, max_lag=10)) <= 10
    with pytest.raises(ParameterError, match="max_lag"):
        estimate_lag(out, ref, max_lag=-1)


def test_raw_p862_from_mos_lqo_round_trip_and_range():
    # Oracle: ITU-T P.862.1's mapping and its stated output range (raw -0.5..4.5 maps to
    # MOS-LQO 1.02..4.55); outside the mapping's range the raw score is clipped.
    from benchmarks.metrics.speech import pesq_raw_from_mos_lqo

    raw = np.linspace(-0.4, 4.4, 49)
    lqo = 0.999 + 4 / (1 + np.exp(-1.4945 * raw + 4.6607))
    np.testing.assert_allclose([pesq_raw_from_mos_lqo(v) for v in lqo], raw, atol=1e-9)
    assert round(0.999 + 4 / (1 + np.exp(-1.4945 * 4.5 + 4.6607)), 2) == 4.55
    assert pesq_raw_from_mos_lqo(4.6) == 4.5 and pesq_raw_from_mos_lqo(1.0) == -0.5
