"""Synthesized noises: determinism per seed, spectral shapes, factory lines, babble talkers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import welch

from data_recipes.local import load_mono, talker_from_name
from data_recipes.ltass import BYRNE_1994_CENTERS_HZ, BYRNE_1994_LEVELS_DB, band_levels_db
from data_recipes.noise_synthesis import (
    GEAR_TEETH,
    MACHINE_HZ,
    MAINS_HZ,
    NOISE_RMS,
    SYNTHESIZABLE,
    SpeechPoolItem,
    synthesize_noise,
)
from scenesim.errors import ParameterError

FS = 16000


def _make(noise_type, seconds=4.0, seed=5, **kw):
    return synthesize_noise(noise_type, int(seconds * FS), fs=FS, rng=np.random.default_rng(seed), **kw)


def _slope_db_per_octave(x: np.ndarray) -> float:
    """Least-squares slope of 10 log10(PSD) against log2(f) over 100 Hz - 6 kHz (Welch, 4096)."""
    f, pxx = welch(x, fs=FS, nperseg=4096)
    band = (f >= 100) & (f <= 6000)
    return float(np.polyfit(np.log2(f[band]), 10 * np.log10(pxx[band]), 1)[0])


@pytest.mark.parametrize("noise_type", ["factory", "wind", "white", "pink", "speech-shaped"])
def test_same_seed_identical_other_seed_different(noise_type):
    a, b, c = _make(noise_type, 2.0, 1), _make(noise_type, 2.0, 1), _make(noise_type, 2.0, 2)
    np.testing.assert_array_equal(a.signal, b.signal)  # oracle: exact reproducibility
    assert not np.allclose(a.signal, c.signal)
    assert a.signal.shape == (1, 2 * FS)
    # Every channel is normalised to NOISE_RMS by construction (float round-off only).
    np.testing.assert_allclose(np.sqrt(np.mean(a.signal**2)), NOISE_RMS, rtol=1e-9)


def test_babble_same_seed_identical():
    a, b = _make("babble", 2.0, 9), _make("babble", 2.0, 9)
    np.testing.assert_array_equal(a.signal, b.signal)
    assert a.components == b.components


def test_pink_falls_3_db_per_octave():
    # Oracle: 1/f power spectrum = -10 log10(2) = -3.01 dB/oct; tolerance +-1 dB/oct.
    slope = _slope_db_per_octave(_make("pink", 10.0).signal[0])
    np.testing.assert_allclose(slope, -3.01, atol=1.0)


def test_white_is_flat():
    # Oracle: white noise has a flat PSD (0 dB/oct); tolerance +-1 dB/oct.
    slope = _slope_db_per_octave(_make("white", 10.0).signal[0])
    np.testing.assert_allclose(slope, 0.0, atol=1.0)


def test_wind_follows_the_inertial_subrange_law_and_stays_low():
    # Oracle: turbulence pressure in the inertial subrange, PSD ~ f^(-7/3) = -7.0 dB/octave
    # above the 100 Hz corner (slope fitted over 400 Hz - 6 kHz, tolerance 0.5 dB/oct: the
    # Welch estimate of 10 s); and the closed-form power split of that shape: 83 % below
    # 200 Hz (flat 0-100 Hz, then f^(-7/3)); > 78 % allows for the gust envelope.
    f, pxx = welch(_make("wind", 10.0).signal[0], fs=FS, nperseg=4096)
    band = (f >= 400) & (f <= 6000)
    slope = float(np.polyfit(np.log2(f[band]), 10 * np.log10(pxx[band]), 1)[0])
    np.testing.assert_allclose(slope, -7.0, atol=0.5)
    assert pxx[f < 200].sum() / pxx.sum() > 0.78


def test_wind_is_gusty():
    # The gust envelope (exp(0.6 g), g ~ N(0,1) at <0.5 Hz) makes 0.5 s RMS vary widely.
    x = _make("wind", 10.0).signal[0]
    rms = np.sqrt(np.mean(x[: 20 * (FS // 2)].reshape(20, -1) ** 2, axis=1))
    assert rms.max() / rms.min() > 1.5


def test_factory_has_lines_at_the_stated_machine_frequencies():
    """PSD at 1 Hz resolution: each stated line stands > 10 dB above the median PSD 5-15 Hz away."""
    x = _make("factory", 10.0).signal[0]
    f, pxx = welch(x, fs=FS, nperseg=FS)  # 1 Hz bins
    lines = [MAINS_HZ, 2 * MAINS_HZ, 3 * MAINS_HZ, MACHINE_HZ, 3 * MACHINE_HZ, GEAR_TEETH * MACHINE_HZ]
    for line in lines:
        k = int(np.argmin(np.abs(f - line)))
        peak = pxx[max(k - 1, 0):k + 2].max()
        around = np.median(np.concatenate([pxx[k - 15:k - 5], pxx[k + 5:k + 15]]))
        assert 10 * np.log10(peak / around) > 10.0, line


def test_factory_has_impulsive_hits():
    # Hammer hits make the 10 ms frame energy heavy-tailed: max frame RMS >> median.
    x = _make("factory", 10.0).signal[0]
    frames = np.sqrt(np.mean(x[: 1000 * 160].reshape(1000, 160) ** 2, axis=1))
    assert frames.max() / np.median(frames) > 3.0


def test_speech_shaped_follows_byrne_ltass():
    """1/3-octave levels of 10 s vs Byrne et al. (1994), best-fit offset, 100 Hz - 6.3 kHz.

    Tolerance 1.5 dB: the noise is shaped exactly to the table; the residual is the
    interpolation within bands plus Welch estimation error.
    """
    x = _make("speech-shaped", 10.0).signal[0]
    keep = (BYRNE_1994_CENTERS_HZ >= 100) & (BYRNE_1994_CENTERS_HZ <= 6300)
    deviation = band_levels_db(x, FS, BYRNE_1994_CENTERS_HZ[keep], nperseg=4096) - BYRNE_1994_LEVELS_DB[keep]
    np.testing.assert_allclose(deviation - deviation.mean(), 0.0, atol=1.5)


def test_builtin_babble_uses_six_distinct_artificial_talkers():
    out = _make("babble", 3.0)
    talkers = {c.split(":")[1] for c in out.components}
    assert len(out.components) == 6 and len(talkers) == 6


def test_babble_from_local_speech_uses_at_least_four_distinct_talkers(shared_data_dir):
    pool = [
        SpeechPoolItem(talker_from_name(p) or p.stem, str(p), load_mono(p, fs=FS))
        for p in sorted((shared_data_dir / "speech").glob("*.wav"))
    ]
    out = _make("babble", 3.0, speech_pool=pool)
    used = [c.rsplit("@", 1)[0] for c in out.components]
    talkers = {talker_from_name(u) or u for u in used}
    assert len(used) == 6 and len(set(used)) == 6
    assert len(talkers) >= 4


def test_two_channels_are_independent():
    # Independent draws: for white noise the sample correlation of 64000 samples has
    # std 1/sqrt(64000) = 0.004; low-frequency wind and babble have far
    # fewer independent samples (std up to ~0.05), hence the 0.2 bound.
    for noise_type in ("white", "wind", "babble"):
        x = _make(noise_type, 4.0, n_channels=2).signal
        assert x.shape == (2, 4 * FS)
        assert abs(np.corrcoef(x)[0, 1]) < 0.2, noise_type


def test_synthesizable_names():
    assert {"babble", "factory", "wind", "white", "pink", "speech-shaped"} <= set(SYNTHESIZABLE)


def test_bad_inputs_name_the_parameter():
    rng = np.random.default_rng(0)
    with pytest.raises(ParameterError, match="noise_type"):
        synthesize_noise("rain", 100, fs=FS, rng=rng)
    with pytest.raises(ParameterError, match="n_samples"):
        synthesize_noise("white", 0, fs=FS, rng=rng)
    with pytest.raises(ParameterError, match="rng"):
        synthesize_noise("white", 10, fs=FS, rng=1)
    with pytest.raises(ParameterError, match="speech_pool"):
        synthesize_noise("babble", 10, fs=FS, rng=rng, speech_pool=[])
