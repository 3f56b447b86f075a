"""The one-pass STOI/ESTOI against pystoi itself (the outside implementation is the oracle)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pystoi import stoi

from benchmarks.metrics.speech import stoi_scores
from benchmarks.metrics.stoi_pair import stoi_estoi


def _pair(rng, fs: int, n: int, noise: float):
    # Speech-like: white noise under a syllabic (20 ms steps) envelope spanning 60 dB.
    env = np.repeat(10 ** rng.uniform(-3, 0, n // 320 + 1), 320)[:n]
    x = rng.standard_normal(n) * env
    y = 0.7 * x + noise * rng.standard_normal(n)
    return x, y


@pytest.mark.parametrize(
    ("fs", "n", "noise"),
    [(16000, 96000, 0.3), (16000, 127745, 1.0), (8000, 40000, 0.1), (10000, 30000, 0.5), (44100, 60000, 0.2)],
)
def test_stoi_and_estoi_equal_pystoi(fs, n, noise):
    # Tolerance 1e-9 (the same operations, vectorised; measured difference 0.0).
    rng = np.random.default_rng(fs + n)
    x, y = _pair(rng, fs, n, noise)
    np.random.seed(0)  # noqa: NPY002 -- pystoi's ESTOI dither comes from the global RNG
    want_stoi = stoi(x, y, fs, extended=False)
    np.random.seed(0)  # noqa: NPY002
    want_estoi = stoi(x, y, fs, extended=True)
    np.random.seed(0)  # noqa: NPY002
    got = stoi_estoi(x, y, fs)
    assert got[0] == pytest.approx(want_stoi, abs=1e-9)
    assert got[1] == pytest.approx(want_estoi, abs=1e-9)
    scores = stoi_scores(x, y, fs=fs)  # the metric layer seeds 0 itself
    assert (scores["stoi"], scores["estoi"]) == pytest.approx((want_stoi, want_estoi), abs=1e-9)


def test_too_few_frames_is_none_where_pystoi_warns():
    rng = np.random.default_rng(3)
    x, y = _pair(rng, 16000, 6000, 0.1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert stoi(x, y, 16000) == 1e-5
    assert any("Not enough STFT frames" in str(w.message) for w in caught)
    assert stoi_estoi(x, y, 16000) is None
