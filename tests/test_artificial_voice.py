"""Built-in artificial voice: determinism, PESQ/STOI acceptance, long-term spectrum vs Byrne et al. (1994)."""

from __future__ import annotations

import numpy as np
import pesq
import pytest
from pystoi import stoi

from data_recipes.artificial_voice import TALKERS, artificial_voice
from data_recipes.ltass import BYRNE_1994_CENTERS_HZ, BYRNE_1994_LEVELS_DB, band_levels_db
from scenesim.errors import ParameterError

FS = 16000


@pytest.fixture(scope="module")
def clean() -> np.ndarray:
    x, _ = artificial_voice(6.0, fs=FS, seed=7)
    return x


def test_same_seed_gives_identical_array_and_other_seeds_differ():
    a, ta = artificial_voice(3.0, fs=FS, seed=11)
    b, tb = artificial_voice(3.0, fs=FS, seed=11)
    c, _ = artificial_voice(3.0, fs=FS, seed=12)
    np.testing.assert_array_equal(a, b)  # oracle: exact reproducibility, tolerance 0
    assert ta == tb
    assert a.shape == (3 * FS,)
    assert not np.allclose(a, c)


def test_length_level_and_finiteness():
    x, _ = artificial_voice(2.5, fs=8000, seed=1, talker="female-2")
    assert x.shape == (20000,)
    assert np.all(np.isfinite(x))
    # RMS is set to -26 dBFS by construction; 1e-9 relative is float round-off.
    np.testing.assert_allclose(np.sqrt(np.mean(x**2)), 0.05, rtol=1e-9)
    assert np.max(np.abs(x)) < 1.0  # no clipping when written as 16-bit PCM


@pytest.mark.parametrize("mode", ["wb", "nb"])
def test_pesq_of_clean_against_itself_is_near_the_maximum(clean, mode):
    # Oracle: ITU-T P.862 / the pesq package: identical signals score the maximum
    # (about 4.64 wb, 4.55 nb); any speech-like input PESQ accepts must exceed 4.0.
    assert pesq.pesq(FS, clean, clean, mode) > 4.0


@pytest.mark.parametrize("mode", ["wb", "nb"])
def test_pesq_drops_monotonically_as_white_noise_is_added(clean, mode):
    # Oracle: PESQ decreases with SNR for additive white noise (P.862 design); real
    # CMU ARCTIC speech gives wb 1.4 / nb 2.2 at 20 dB, wb 1.0-1.1 / nb 1.2-1.4 at 0 dB.
    rng = np.random.default_rng(3)
    white = rng.standard_normal(clean.size)
    scores = []
    for snr_db in (20.0, 10.0, 0.0):
        gain = np.sqrt(np.mean(clean**2) / np.mean(white**2) / 10 ** (snr_db / 10))
        scores.append(pesq.pesq(FS, clean, clean + gain * white, mode))
    assert scores[0] > scores[1] > scores[2], scores
    assert scores[0] < 4.0  # 20 dB of white noise is clearly audible


def test_stoi_of_clean_against_itself_is_one(clean):
    # Oracle: STOI (Taal et al. 2011) of a signal with itself is 1 (correlation of identical envelopes).
    assert stoi(clean, clean, FS) > 0.99


@pytest.mark.parametrize("talker", ["male-1", "female-1"])
def test_long_term_spectrum_follows_byrne_1994_ltass_within_6_db(talker):
    """1/3-octave band levels (Welch, 4096-point Hann) of a 20 s clip vs the universal LTASS.

    Reference: Byrne et al. (1994) table (data_recipes.ltass), bands 100 Hz - 6.3 kHz,
    compared after removing the best-fit (mean) offset.  Tolerance: 6 dB per band.
    """
    x, _ = artificial_voice(20.0, fs=FS, seed=2, talker=talker)
    keep = (BYRNE_1994_CENTERS_HZ >= 100) & (BYRNE_1994_CENTERS_HZ <= 6300)
    measured = band_levels_db(x, FS, BYRNE_1994_CENTERS_HZ[keep], nperseg=4096)
    deviation = measured - BYRNE_1994_LEVELS_DB[keep]
    deviation -= deviation.mean()
    np.testing.assert_allclose(deviation, 0.0, atol=6.0)


def test_talkers_cover_male_and_female_f0_ranges():
    # P.50-like ranges: male ~110-130 Hz, female ~200-230 Hz; six distinct talkers for babble.
    males = [t.f0_hz for t in TALKERS if t.sex == "male"]
    females = [t.f0_hz for t in TALKERS if t.sex == "female"]
    assert min(males) >= 105 and max(males) <= 135
    assert min(females) >= 195 and max(females) <= 235
    assert len({t.name for t in TALKERS}) == 6


def test_bad_inputs_name_the_parameter():
    with pytest.raises(ParameterError, match="duration_s"):
        artificial_voice(0.0, fs=FS, seed=0)
    with pytest.raises(ParameterError, match="talker"):
        artificial_voice(1.0, fs=FS, seed=0, talker="nobody")
    with pytest.raises(ParameterError, match="fs"):
        artificial_voice(1.0, fs=4000, seed=0)


def test_overlap_add_formant_filter_equals_recursive_cascade_for_fixed_formants():
    """Oracle: scipy.signal.sosfilt of the same resonator cascade (static formants).

    With constant formants the windowed overlap-add is an LTI filter whose Hann windows
    sum to one; the only error is the impulse-response tail beyond the 45 ms FFT margin
    (resonator bandwidth 80 Hz: exp(-pi 80 0.045) ~ 1e-5), hence rtol 1e-4 of the peak.
    """
    from scipy.signal import sosfilt

    from data_recipes.artificial_voice import _BANDWIDTHS_HZ, _formant_filter, _resonator_sos

    x = np.random.default_rng(0).standard_normal(FS)
    formants = np.array([500.0, 1500.0, 2500.0, 3500.0])
    hop = 80
    fast = _formant_filter(x, np.tile(formants, (FS // hop + 2, 1)), hop, FS)
    slow = sosfilt(_resonator_sos(formants, _BANDWIDTHS_HZ, FS), x)
    np.testing.assert_allclose(fast, slow, atol=1e-4 * np.max(np.abs(slow)))
