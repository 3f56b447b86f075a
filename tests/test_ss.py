"""Spectral subtraction (Martin 1994 and 2001 trackers): behaviour on noise and speech, replay, streaming."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import soundfile
from signals import FS, harmonic_speechlike

from enhancers.ss import SpectralSubtraction, SpectralSubtractionMS2001, subtraction_gain
from scenesim.errors import ParameterError

CLASSES = [SpectralSubtraction, SpectralSubtractionMS2001]


def _level_db(x):
    return 10 * np.log10(np.mean(np.square(x)))


@pytest.mark.parametrize("cls", CLASSES)
def test_noise_alone_is_at_least_10_db_quieter(cls, rng):
    """Stationary white noise alone: after the initial window (2 s) the output is >= 10 dB below
    the input (oracle: the issue target; the noise floor is subf^2 = -34 dB below the noise)."""
    e = cls()
    x = 0.05 * rng.standard_normal((1, 5 * FS))
    y = e.process(x, FS).output
    L, start = e.tags.latency_samples, 2 * FS
    assert _level_db(x[:, start:-L]) - _level_db(y[:, start + L:]) >= 10.0


def _speech_level_change(e, s):
    y = e.process(s[None], FS).output[0]
    L = e.tags.latency_samples
    return _level_db(y[L:]) - _level_db(s[:-L])


@pytest.mark.parametrize("cls", CLASSES)
def test_clean_speechlike_signal_keeps_its_level(cls):
    """Clean amplitude-modulated harmonic signal with pauses: output level within 1 dB of the input."""
    s = harmonic_speechlike(5 * FS)
    assert abs(_speech_level_change(cls(), s)) <= 1.0


@pytest.mark.parametrize("cls", CLASSES)
def test_clean_real_speech_keeps_its_level(cls, shared_data_dir):
    """Real CMU ARCTIC utterances (concatenated, ~10 s): output level within 1 dB of the input."""
    files = sorted((shared_data_dir / "speech").glob("cmu_arctic_us_aew_*.wav"))[:3]
    s = np.concatenate([soundfile.read(f, dtype="float64")[0] for f in files])
    assert abs(_speech_level_change(cls(), s)) <= 1.0


@pytest.mark.parametrize("cls", CLASSES)
def test_replay_is_exact_and_linear(cls, rng):
    """Shadow filtering: replay(mixture) == output and replay(s) + replay(n) == replay(s + n), to 1e-9."""
    e = cls()
    s = harmonic_speechlike(2 * FS)[None]
    n = 0.1 * rng.standard_normal((1, 2 * FS))
    r = e.process(s + n, FS)
    np.testing.assert_allclose(r.replay(s + n), r.output, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.replay(s) + r.replay(n), r.output, rtol=0, atol=1e-9)
    assert r.trace["gain"].shape == (2 * FS // 128, 129)


@pytest.mark.parametrize("cls", CLASSES)
def test_streaming_equals_batch(cls, rng):
    """Blocks of 1, hop (128) and 97 samples give the batch output (to 1e-9); states are picklable."""
    e = cls()
    x = rng.standard_normal((1, 1500))
    ref = e.process(x, FS).output
    for block in (1, 128, 97):
        state, parts = e.init_state(FS), []
        for i in range(0, x.shape[-1], block):
            out, state = e.process_block(x[:, i:i + block], state)
            parts.append(out)
        np.testing.assert_allclose(np.concatenate(parts, axis=-1), ref, rtol=0, atol=1e-9)
        pickle.loads(pickle.dumps(state))


def test_snr_improves_on_speech_in_white_noise(rng):
    """Speech-like signal + white noise at 5 dB: shadow-filtered output SNR improves by >= 5 dB."""
    e = SpectralSubtraction()
    s = harmonic_speechlike(5 * FS)[None]
    n = rng.standard_normal((1, 5 * FS))
    n *= np.sqrt(np.mean(s**2) / np.mean(n**2) / 10 ** 0.5)
    r = e.process(s + n, FS)
    start = 2 * FS
    snr_out = _level_db(r.replay(s)[:, start:]) - _level_db(r.replay(n)[:, start:])
    assert snr_out - 5.0 >= 5.0


def test_subtraction_rule_matches_formula():
    """Oracle: the Berouti rule written out for one bin (osub at SNR 10 dB is 4 - 1.5 = 2.5)."""
    X, Pn = np.array([3.0]), np.array([1.0])
    P = 10 * Pn
    g = subtraction_gain(X, P, Pn, osub0=4, osub_slope=0.15, osub_min=1, osub_max=4.75, subf=0.02)
    np.testing.assert_allclose(g, (3 - np.sqrt(2.5)) / 3, rtol=1e-14)
    g_floor = subtraction_gain(np.array([0.5]), P, Pn, osub0=4, osub_slope=0.15, osub_min=1, osub_max=4.75, subf=0.02)
    np.testing.assert_allclose(g_floor, 0.02 / 0.5, rtol=1e-14)


def test_thesis_preset_and_json_round_trip():
    p = SpectralSubtraction.Params.thesis()
    assert (p.n_sub * p.sub_len, p.omin) == (200, 0.99)
    assert SpectralSubtraction.Params.from_json(p.to_json()) == p
    q = SpectralSubtractionMS2001.Params(td=1.0)
    assert SpectralSubtractionMS2001.Params.from_json(q.to_json()) == q


@pytest.mark.parametrize("cls,kwargs,name", [
    (SpectralSubtraction, {"alpha": 1.0}, "alpha"), (SpectralSubtraction, {"hop": 100}, "hop"),
    (SpectralSubtraction, {"omin": -1.0}, "omin"), (SpectralSubtraction, {"snr_def": "x"}, "snr_def"),
    (SpectralSubtraction, {"subf": 2.0}, "subf"), (SpectralSubtraction, {"n_sub": 0}, "n_sub"),
    (SpectralSubtractionMS2001, {"td": 0.0}, "td"), (SpectralSubtractionMS2001, {"qeqmin": 0.5}, "qeqmin"),
])
def test_bad_params_name_the_field(cls, kwargs, name):
    with pytest.raises(ParameterError, match=name):
        cls(**kwargs)


def test_floor_never_amplifies_a_bin_by_default_regression_replay_cross_term():
    """Regression: bins below the floor got gains up to 1000 and replay SNR described the mask.

    Oracle: the rule written out.  |X| = 0.01 is below subf sqrt(Pn) = 0.02, so the literal
    Berouti rule gives G = 2; the default caps it at 1, gain_max=1000 keeps the literal rule.
    """
    X, Pn, P = np.array([0.01]), np.array([1.0]), np.array([1.0])
    kw = dict(osub0=4, osub_slope=0.15, osub_min=1, osub_max=4.75, subf=0.02)
    np.testing.assert_allclose(subtraction_gain(X, P, Pn, **kw), 1.0, rtol=1e-14)
    np.testing.assert_allclose(subtraction_gain(X, P, Pn, gain_max=1e3, **kw), 2.0, rtol=1e-14)
    with pytest.raises(ParameterError, match="gain_max"):
        SpectralSubtraction(gain_max=0.5)


def test_gain_mask_is_at_most_one_on_speech_in_noise(rng):
    """With the default gain_max the recorded mask never exceeds 1 (no bin is amplified)."""
    t = np.arange(3 * FS) / FS
    s = 0.1 * np.sin(2 * np.pi * 200 * t) * (np.sin(2 * np.pi * 3 * t) > 0)
    x = (s + 0.05 * rng.standard_normal(t.size))[None]
    g = SpectralSubtraction().process(x, FS).trace["gain"]
    assert g.max() <= 1.0 + 1e-12
