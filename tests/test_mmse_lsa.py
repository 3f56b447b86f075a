"""MMSE-LSA (Ephraim & Malah 1985): gain rule vs the closed form, noise-only attenuation,
speech+noise at 5 dB against ``ss``, replay and streaming."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import exp1
from signals import FS, harmonic_speechlike

from enhancers.single.mmse_lsa import MmseLsa, dd_prior_snr, lsa_gain
from enhancers.single.ss import SpectralSubtraction
from scenesim.errors import ParameterError


def _level_db(x):
    return 10 * np.log10(np.mean(np.square(x)))


def test_gain_matches_closed_form_on_a_grid():
    """Oracle: EM85 eq. 20 written out with scipy.special.exp1 per point (rtol 1e-12);
    the grid spans xi, gamma from -30 to +30 dB, where the uncapped gain stays below 1 except
    at low gamma, so the cap is checked separately."""
    xi = 10 ** (np.linspace(-30, 30, 25) / 10)
    gamma = 10 ** (np.linspace(-30, 30, 31) / 10)
    got = lsa_gain(xi[:, None], gamma[None, :], gain_max=1e3)
    want = np.array([[a / (1 + a) * np.exp(0.5 * exp1(a * g / (1 + a))) for g in gamma] for a in xi])
    np.testing.assert_allclose(got, want, rtol=1e-12)
    # Known limits: large gamma -> Wiener gain xi / (1 + xi) (E1 -> 0); the cap holds.
    np.testing.assert_allclose(lsa_gain(np.array(1.0), np.array(1e4)), 0.5, rtol=1e-12)
    assert np.all(lsa_gain(xi[:, None], gamma[None, :]) <= 1.0)


def test_decision_directed_prior_snr_formula():
    """EM84 eq. 51 for one bin: 0.98 * 4 + 0.02 * max(9 - 1, 0) = 4.08; floored at xi_min."""
    np.testing.assert_allclose(dd_prior_snr(np.array([9.0]), np.array([4.0]), alpha=0.98, xi_min=0.01), 4.08)
    np.testing.assert_allclose(dd_prior_snr(np.array([0.5]), None, alpha=0.98, xi_min=0.01), 0.01)


def test_stationary_noise_alone_is_attenuated_by_18_to_22_db(rng):
    """White noise alone, after the tracker's 2 s start: measured 19.6 dB attenuation (3 seeds);
    the bound [18, 22] dB brackets it.  Physical ceiling: the LSA gain at xi = xi_min = -25 dB and
    gamma = 1 is -27.5 dB, and fluctuations of gamma raise the average gain above it."""
    e = MmseLsa()
    x = 0.05 * rng.standard_normal((1, 5 * FS))
    y = e.process(x, FS).output
    L, start = e.tags.latency_samples, 2 * FS
    att = _level_db(x[:, start:-L]) - _level_db(y[:, start + L:])
    assert 18.0 <= att <= 22.0


def _snr_and_distortion(e, s, n):
    r = e.process(s + n, FS)
    L, start = e.tags.latency_samples, 2 * FS
    ys, yn = r.replay(s), r.replay(n)
    snr_i = _level_db(ys[:, start:]) - _level_db(yn[:, start:]) - 5.0
    # Speech distortion: speech component of the output against the delayed clean speech.
    sd = _level_db(s[:, start:-L]) - _level_db(ys[:, start + L:] - s[:, start:-L])
    return snr_i, sd


def test_speech_in_white_noise_at_5_db_against_ss(rng):
    """Speech-like signal + white noise at 5 dB, shadow filtering (seeded).

    Measured: mmse-lsa SNR-I 12.0 dB, ss 15.4 dB (Berouti over-subtraction removes more noise);
    speech-to-distortion ratio of the speech component 14.6 dB for mmse-lsa vs 11.4 dB for ss
    (LSA keeps the speech).  Pinned: SNR-I >= 11.5 dB and a distortion advantage >= 2.5 dB.
    """
    s = harmonic_speechlike(5 * FS)[None]
    n = rng.standard_normal((1, 5 * FS))
    n *= np.sqrt(np.mean(s**2) / np.mean(n**2) / 10 ** 0.5)
    lsa_snr_i, lsa_sd = _snr_and_distortion(MmseLsa(), s, n)
    _, ss_sd = _snr_and_distortion(SpectralSubtraction(), s, n)
    assert lsa_snr_i >= 11.5
    assert lsa_sd - ss_sd >= 2.5


def test_replay_is_exact_and_streaming_equals_batch(rng):
    """replay(mixture) == output and blocks of 1, 128, 97 samples == batch (both to 1e-9)."""
    e = MmseLsa()
    x = 0.1 * rng.standard_normal((1, 3000))
    r = e.process(x, FS)
    np.testing.assert_allclose(r.replay(x), r.output, rtol=0, atol=1e-9)
    assert r.trace["gain"].shape == (3000 // 128, 129)
    for block in (1, 128, 97):
        state, parts = e.init_state(FS), []
        for i in range(0, x.shape[-1], block):
            out, state = e.process_block(x[:, i:i + block], state)
            parts.append(out)
        np.testing.assert_allclose(np.concatenate(parts, axis=-1), r.output, rtol=0, atol=1e-9)


@pytest.mark.parametrize(("kwargs", "name"), [({"alpha": 1.0}, "alpha"), ({"xi_min_db": float("nan")}, "xi_min_db"),
                                              ({"gain_max": 0.5}, "gain_max"), ({"hop": 100}, "hop")])
def test_bad_params_name_the_field(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        MmseLsa(**kwargs)
