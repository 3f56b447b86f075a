"""Gerkmann & Hendriks' SPP and unbiased MMSE noise PSD estimator (enhancers.single.spp).

Oracles: the closed-form expectations of one update in noise alone (integrals over the exponential
law of a complex Gaussian periodogram, scipy.integrate.quad), the physical behaviour in noise alone
and for a tone 30 dB above it, and the step split at arbitrary frames (streaming = batch).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from enhancers.core.filterbank import FilterBank
from enhancers.single.spp import SppConfig, SppState, spp_init, spp_posterior, spp_step
from scenesim.errors import ParameterError

XI = 10 ** 1.5  # the paper's a-priori SNR under speech, 15 dB


def _p(x):
    return 1.0 / (1.0 + (1.0 + XI) * math.exp(-x * XI / (1.0 + XI)))


def test_one_update_in_noise_alone_matches_the_closed_form_integrals(rng):
    # x = |Y|^2 / sigma2 ~ Exp(1) at the true PSD: E[P] and E[(1 - P) x + P] by quadrature.
    mean_p = quad(lambda x: _p(x) * math.exp(-x), 0, np.inf)[0]
    mean_e = quad(lambda x: ((1 - _p(x)) * x + _p(x)) * math.exp(-x), 0, np.inf)[0]
    n = 400_000
    S = rng.exponential(1.0, size=(1, n))
    cfg = SppConfig()
    P, sigma2, _ = spp_step(S, SppState(sigma2=np.ones(n), p_bar=np.zeros(n)), cfg)
    a_n = cfg.alphas()[0]
    # tolerance: 5 Monte-Carlo standard errors (sd of P ~0.3, of the estimate ~1) over 4e5 draws
    assert P.mean() == pytest.approx(mean_p, abs=5 * 0.3 / math.sqrt(n))
    assert sigma2.mean() == pytest.approx(a_n + (1 - a_n) * mean_e, abs=5 * 1.0 / math.sqrt(n))
    assert mean_p == pytest.approx(0.104, abs=0.001) and mean_e == pytest.approx(0.878, abs=0.001)


def test_noise_alone_spp_stays_low_and_the_estimate_within_1p5_db(rng):
    fb = FilterBank()
    S = np.abs(fb.analyze(rng.standard_normal((1, 16000 * 20)))[0]) ** 2
    P, sigma2, _ = spp_step(S, spp_init(S.shape[1]), SppConfig())
    true = S.mean(axis=0)
    bias_db = 10 * np.log10(sigma2[200:].mean(axis=0) / true)[2:-2]  # DC and Nyquist bins are real-valued
    assert np.all(np.abs(bias_db) <= 1.5)  # measured -0.9 .. -1.2 dB (module docstring)
    assert P[200:].mean() < 0.2  # prior 0.5; one update's closed form at the true PSD is 0.104


def test_a_tone_30_db_above_the_noise_has_spp_near_one(rng):
    fs, fb = 16000, FilterBank()
    k = 40  # bin 40: 2500 Hz, centred, so the tone stays in one bin
    n = fs * 4
    noise = rng.standard_normal(n)
    w = fb.analysis_window
    # tone power in its bin (A sum(w) / 2)^2 = 1000 x the noise's bin power sum(w^2)
    amp = 2.0 * math.sqrt(1000.0 * np.sum(w**2)) / np.sum(w)
    t = np.arange(n) / fs
    tone = np.where(t >= 2.0, amp * np.cos(2 * np.pi * k * fs / fb.frame_len * t), 0.0)
    S = np.abs(fb.analyze((noise + tone)[None])[0]) ** 2
    P, _, _ = spp_step(S, spp_init(S.shape[1]), SppConfig())
    onset = int(2.0 * fs) // fb.hop + 2  # the first frame fully inside the tone
    assert np.all(P[onset:onset + 30, k] >= 0.99)  # 0.24 s of tone
    assert P[100:onset - 2, k].mean() < 0.2  # before it: noise alone


@pytest.mark.parametrize("cut", [1, 7, 250])
def test_streaming_equals_batch(rng, cut):
    S = rng.exponential(1.0, size=(400, 9))
    S[150:] *= 100.0  # a 20 dB step the estimate must climb: the stagnation guard (p_bar) engages
    cfg = SppConfig()
    P, s2, end = spp_step(S, spp_init(9), cfg)
    parts, state = [], spp_init(9)
    for i in range(0, 400, cut):
        p, s, state = spp_step(S[i:i + cut], state, cfg)
        parts.append((p, s))
    np.testing.assert_allclose(np.concatenate([a for a, _ in parts]), P, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.concatenate([b for _, b in parts]), s2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(state.sigma2, end.sigma2, rtol=0, atol=1e-15)


def test_silence_gives_the_prior_odds_value_and_no_nan():
    P, sigma2, _ = spp_step(np.zeros((5, 4)), spp_init(4), SppConfig())
    assert np.all(sigma2 == 0.0)
    np.testing.assert_allclose(P, float(spp_posterior(0.0, xi=XI, prior_odds=1.0)), rtol=1e-12)


def test_bad_config_names_the_parameter():
    with pytest.raises(ParameterError, match="prior_h1"):
        SppConfig(prior_h1=1.0)
    with pytest.raises(ParameterError, match="hop_s"):
        SppConfig(hop_s=0.0)
