"""Powers, active speech level and mixing at a target SNR (thesis eq. 7.1).

Oracles: the definition 10 log10(P_s / P_n) recomputed with numpy for the mixture's
components; for the active level, the known on-fraction of gated noise bursts.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.scene.mixing import (
    P56_HANGOVER_S,
    active_speech_power,
    mix_at_snr,
    noise_gain_for_snr,
    signal_power,
)

FS = 16000


def gated_noise(rng, *, on_s, period_s, total_s):
    n = int(total_s * FS)
    gate = (np.arange(n) % int(period_s * FS)) < int(on_s * FS)
    return rng.standard_normal(n) * gate


@pytest.mark.parametrize("snr_db", [-5.0, 0.0, 12.5])
@pytest.mark.parametrize("mode", ["total", "active"])
def test_mixture_snr_equals_target(rng, snr_db, mode):
    # Oracle: 10 log10(P_s / P_n) of the returned components, recomputed; tolerance 0.01 dB.
    speech = np.stack([gated_noise(rng, on_s=0.4, period_s=1.0, total_s=4.0)] * 2)
    noise = rng.standard_normal((2, speech.shape[1])) * 3.0
    mixture, scaled, g = mix_at_snr(speech, noise, snr_db, mode=mode, fs=FS)
    np.testing.assert_allclose(mixture, speech + scaled, atol=1e-12)
    p_s = active_speech_power(speech[0], FS) if mode == "active" else np.mean(speech[0] ** 2)
    np.testing.assert_allclose(10 * np.log10(p_s / np.mean(scaled[0] ** 2)), snr_db, atol=0.01)
    np.testing.assert_allclose(scaled, g * noise, rtol=1e-12)


def test_active_level_of_gated_noise(rng):
    # Oracle: activity = on time + 0.2 s hangover per burst, so the active power is
    # P_on * on / (on + hangover); tolerance 0.5 dB (the envelope's ~0.07 s decay tail
    # before the hangover starts is not in the formula: ~0.25 dB).
    for on_s, period_s in [(1.0, 2.0), (0.5, 2.0)]:
        x = gated_noise(rng, on_s=on_s, period_s=period_s, total_s=12.0)
        p_on = np.mean(x[x != 0] ** 2)
        expected = p_on * on_s / (on_s + P56_HANGOVER_S)
        np.testing.assert_allclose(
            10 * np.log10(active_speech_power(x, FS)), 10 * np.log10(expected), atol=0.5
        )


def test_active_level_of_stationary_noise_is_its_power(rng):
    # A continuously active signal: active level = total power (0.1 dB).
    x = rng.standard_normal(5 * FS)
    np.testing.assert_allclose(
        10 * np.log10(active_speech_power(x, FS) / signal_power(x)), 0.0, atol=0.1
    )


def test_active_level_is_scale_covariant(rng):
    x = gated_noise(rng, on_s=0.3, period_s=1.0, total_s=5.0)
    np.testing.assert_allclose(
        active_speech_power(10 * x, FS), 100 * active_speech_power(x, FS), rtol=1e-9
    )


def test_silence_has_zero_power():
    assert active_speech_power(np.zeros(1000), FS) == 0.0
    assert signal_power(np.zeros((2, 10))) == 0.0


def test_inputs_not_mutated(rng):
    s, n = rng.standard_normal((2, 2, 500))
    s0, n0 = s.copy(), n.copy()
    mix_at_snr(s, n, 3.0)
    np.testing.assert_array_equal(s, s0)
    np.testing.assert_array_equal(n, n0)


def test_bad_inputs_raise(rng):
    s = rng.standard_normal(1000)
    with pytest.raises(ParameterError, match="mode"):
        noise_gain_for_snr(s, s, 0.0, mode="peak")
    with pytest.raises(ParameterError, match="fs"):
        noise_gain_for_snr(s, s, 0.0, mode="active")
    with pytest.raises(ParameterError, match="noise_ref"):
        noise_gain_for_snr(s, np.zeros(1000), 0.0)
    with pytest.raises(ParameterError, match="speech_ref"):
        noise_gain_for_snr(np.zeros(1000), s, 0.0)
    with pytest.raises(ParameterError, match="snr_db"):
        noise_gain_for_snr(s, s, float("nan"))
    with pytest.raises(ParameterError, match="noise"):
        mix_at_snr(np.ones((2, 10)), np.ones((2, 11)), 0.0)
    with pytest.raises(ParameterError, match="ref_channel"):
        mix_at_snr(np.ones((2, 10)), np.ones((2, 10)), 0.0, ref_channel=2)
