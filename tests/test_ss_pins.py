"""Spectral subtraction pinned at the enhancer level: noise estimate, attenuation, SNR improvement.

A mutation audit (issue 11) found that removing or halving the bias compensation in
``SpectralSubtraction._tracker_step``, or using the instantaneous instead of the smoothed
SNR in the Berouti rule, survived the whole suite.  These tests pin what those choices
do, on white noise of a stated seed (20121122, the ``rng`` fixture).

Measured for the default ``ss`` (seed 20121122; seeds 1-3 in brackets), and for the
mutants it must tell apart:

    ============================  =========  ======================  ====================
    variant                       noise est  white-noise attenuation  SNR-I at 5 dB input
    ============================  =========  ======================  ====================
    default (smoothed, omin)      +0.04 dB   26.3 dB (25.8-26.6)      15.16 dB (15.17-15.31)
    instantaneous SNR             +0.04 dB   22.9 dB                  14.49 dB
    omin = 1 (no compensation)    -2.45 dB   17.3 dB                  12.19 dB
    omin halved (0.885)           -2.98 dB   15.8 dB                  11.44 dB
    ============================  =========  ======================  ====================

(script: the body of these tests, printed; 6 s signals, the first 2 s skipped.)
"""

from __future__ import annotations

import numpy as np
import pytest
from signals import FS, harmonic_speechlike

from enhancers.single.ss import SpectralSubtraction

WARMUP_S = 2  # the minimum tracker's window is 1.5 s: skip it


def _level_db(x) -> float:
    return 10 * np.log10(np.mean(np.square(x)))


@pytest.fixture(scope="module")
def white():
    return 0.05 * np.random.default_rng(20121122).standard_normal((1, 6 * FS))


def test_noise_estimate_is_unbiased_on_stationary_noise(white):
    """``trace['noise_psd']`` within 1 dB of the true mean periodogram (oracle: the average of
    ``|X|^2`` of the same frames, interior bins, after the warm-up).  Without the bias
    compensation the minimum sits 2.45 dB low (1 / 1.77); halved, 2.98 dB."""
    e = SpectralSubtraction()
    noise_psd = e.process(white, FS).trace["noise_psd"]
    S = np.abs(e.filterbank.analyze(white)[0]) ** 2
    f0 = WARMUP_S * FS // e.params.hop
    bias_db = 10 * np.log10(noise_psd[f0:, 2:-2].mean() / S[f0:, 2:-2].mean())
    assert abs(bias_db) <= 1.0


def test_white_noise_attenuation_pinned(white):
    """Noise alone: 26.3 dB attenuation, +-1.5 dB (seeds 1-3 span 25.8-26.6; the instantaneous
    SNR gives 22.9 dB, no bias compensation 17.3 dB)."""
    e = SpectralSubtraction()
    y = e.process(white, FS).output
    L, start = e.tags.latency_samples, WARMUP_S * FS
    attenuation_db = _level_db(white[:, start:-L]) - _level_db(y[:, start + L:])
    assert attenuation_db == pytest.approx(26.3, abs=1.5)


def test_snr_improvement_pinned(rng):
    """Harmonic speech-like signal + white noise at 5 dB, shadow filtered: SNR-I 15.16 dB, +-0.4 dB
    (seeds 1-3 span 15.17-15.31; the instantaneous SNR gives 14.49 dB, no compensation 12.19 dB)."""
    rng.standard_normal((1, 6 * FS))  # the `white` fixture's draw, so this test's noise is the one measured
    e = SpectralSubtraction()
    s = harmonic_speechlike(6 * FS)[None]
    v = rng.standard_normal((1, 6 * FS))
    v *= np.sqrt(np.mean(s**2) / np.mean(v**2) / 10**0.5)
    r = e.process(s + v, FS)
    start = WARMUP_S * FS
    snr_i = _level_db(r.replay(s)[:, start:]) - _level_db(r.replay(v)[:, start:]) - 5.0
    assert snr_i == pytest.approx(15.16, abs=0.4)
