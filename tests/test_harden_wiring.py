"""Issue 33: correct functions wired into the right row columns (G.160 footing, attribution's sign).

Kept apart from the report's own test files (another change is under way there).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal as ss

from benchmarks.metrics.g160 import (
    G160_COLUMNS,
    G160_EXACT_COLUMNS,
    g160_measures,
    g160_measures_blackbox,
)
from benchmarks.metrics.row_measures import attribution_columns, g160_columns

FS = 16000


def _talk_with_pauses(rng, seconds=6.0):
    """A harmonic talker, 0.6 s words and 0.6 s pauses (G.160 needs both kinds of frames)."""
    t = np.arange(int(seconds * FS)) / FS
    voiced = sum(np.sin(2 * np.pi * 130 * k * t) / k for k in range(1, 25))
    gate = (np.floor(t / 0.6) % 2 == 0).astype(float)
    return 0.1 * voiced * gate


def test_g160_white_and_black_box_columns_come_from_their_own_measures(rng):
    # Oracle: the two measures called directly.  A system that halves the noise and scales the
    # speech by 0.9 (replayable parts known): the headline columns are the estimate from mixture
    # and output for every system, the *_exact columns the replayed parts' values -- not swapped.
    s = _talk_with_pauses(rng)
    n = 0.02 * rng.standard_normal(s.size)
    s_out, n_out = 0.9 * s, 0.5 * n
    row = g160_columns(s, FS, mixture=s + n, output=s_out + n_out, parts=(s, n, s_out, n_out))
    black = g160_measures_blackbox(s, s + n, s_out + n_out, FS)
    white = g160_measures(s, s, n, s_out, n_out, FS)
    for col, exact in zip(G160_COLUMNS, G160_EXACT_COLUMNS):
        assert row[col] == pytest.approx(black[col], rel=1e-12, abs=1e-12), col
        assert row[exact] == pytest.approx(white[col], rel=1e-12, abs=1e-12), exact
    # Closed form of the exact SNRI: the noise falls 6.02 dB, the speech 0.92 dB (1e-6 dB).
    assert row["g160_snri_exact_db"] == pytest.approx(20 * math.log10(0.9 / 0.5), abs=1e-6)
    # Without replayable parts there is no exact value, and the estimate stays.
    blind = g160_columns(s, FS, mixture=s + n, output=s_out + n_out)
    assert all(blind[c] is None for c in G160_EXACT_COLUMNS) and blind["g160_snri_db"] == row["g160_snri_db"]


def test_attribution_gives_a_spatial_gain_to_the_spatial_column_with_its_sign(rng):
    # Oracle: closed forms.  A system that leaves the speech alone and halves the noise (what a
    # spatial null does) gains 20 log10 2 = 6.02 dB of SNR, none of it from spectral shaping:
    # spectral 0, spatial +6.02.  A low-pass on both parts is all spectral: spatial 0.
    s, n = rng.standard_normal(2 * FS), rng.standard_normal(2 * FS)
    spatial = attribution_columns(s, n, s, 0.5 * n, FS, snr_i_db=20 * math.log10(2))
    assert spatial["snr_i_spectral_db"] == pytest.approx(0.0, abs=0.05)
    assert spatial["snr_i_spatial_db"] == pytest.approx(20 * math.log10(2), abs=0.05)
    b, a = ss.butter(4, 1000, fs=FS)
    speech = 0.3 * ss.lfilter([1, 0.9], [1], rng.standard_normal(2 * FS))  # low-heavy speech
    sl, nl = ss.lfilter(b, a, speech), ss.lfilter(b, a, n)
    total = 10 * math.log10(np.sum(sl**2) / np.sum(nl**2)) - 10 * math.log10(np.sum(speech**2) / np.sum(n**2))
    spectral = attribution_columns(speech, n, sl, nl, FS, snr_i_db=total)
    assert total > 2.0
    assert spectral["snr_i_spectral_db"] == pytest.approx(total, abs=0.3)
    assert spectral["snr_i_spatial_db"] == pytest.approx(0.0, abs=0.3)
