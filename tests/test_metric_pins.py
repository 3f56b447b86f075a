"""PESQ and STOI pinned on degraded speech the repo generates itself (no ../shared needed).

The pair: 3 s of the built-in artificial voice (``artificial_voice(3.0, seed=0)``) and the
same plus white Gaussian noise at 20 dB SNR (``default_rng(20121122)``).  Oracles: the
``pesq`` (P.862 / P.862.2) and ``pystoi`` packages as installed, computed once by this
file's code and pinned to 1e-4 (both are deterministic; 1e-4 leaves room for float
rounding across platforms and is 50x below the smallest swap difference below).  The
pins catch our wrappers passing the arguments in the wrong order (issue 11's surviving
mutation): with reference and degraded swapped every score moves by at least 0.0056
(wide-band PESQ), STOI by 0.13.  If the artificial voice changes on purpose, recompute
the pins (and say so in the commit).
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.metrics import pesq_scores, stoi_scores
from data_recipes.artificial_voice import artificial_voice

FS = 16000
PINS = {"nb": 1.6660494804382324, "wb": 1.0864803791046143, "stoi": 0.9848673486428187, "estoi": 0.9558747558506938}
SWAPPED = {"nb": 1.4334584474563599, "wb": 1.0808569192886353, "stoi": 0.8502118360181813, "estoi": 0.7021401429284565}
TOL = 1e-4


@pytest.fixture(scope="module")
def pair():
    speech, _ = artificial_voice(3.0, fs=FS, seed=0)
    noise = np.random.default_rng(20121122).standard_normal(speech.size)
    noise *= np.sqrt(np.mean(speech**2) / np.mean(noise**2) / 10**2.0)  # 20 dB SNR
    return speech, speech + noise


@pytest.fixture(scope="module")
def scores(pair):
    reference, degraded = pair
    return {**pesq_scores(reference, degraded, fs=FS), **stoi_scores(reference, degraded, fs=FS)}


@pytest.mark.parametrize("key", list(PINS))
def test_score_of_the_generated_pair_is_pinned(scores, key):
    assert scores[key] == pytest.approx(PINS[key], abs=TOL)


@pytest.mark.parametrize("key", list(PINS))
def test_swapping_reference_and_degraded_would_fail_the_pin(key):
    # The pins are only worth having if the swapped call lands outside their tolerance.
    assert abs(SWAPPED[key] - PINS[key]) > 50 * TOL


def test_swapped_call_really_gives_the_swapped_scores(pair):
    reference, degraded = pair
    swapped = {**pesq_scores(degraded, reference, fs=FS), **stoi_scores(degraded, reference, fs=FS)}
    for key in PINS:
        assert swapped[key] == pytest.approx(SWAPPED[key], abs=TOL)


def test_estoi_is_repeatable_and_leaves_the_global_rng_alone(pair):
    # pystoi dithers ESTOI with np.random; unseeded, the swapped pair's ESTOI moved by ~5e-4
    # from call to call.  stoi_scores seeds it (whatever the global state was before) and
    # restores the caller's global state afterwards.
    reference, degraded = pair
    saved = np.random.get_state()  # noqa: NPY002 - the global RNG pystoi uses is the subject
    try:
        values = []
        for global_seed in (1, 2):
            np.random.seed(global_seed)  # noqa: NPY002
            before = np.random.get_state()  # noqa: NPY002
            values.append(stoi_scores(degraded, reference, fs=FS)["estoi"])
            after = np.random.get_state()  # noqa: NPY002
            assert np.array_equal(before[1], after[1]) and before[2:] == after[2:]
        assert values[0] == values[1]
    finally:
        np.random.set_state(saved)  # noqa: NPY002


def test_wideband_pesq_labelled_on_speech_upsampled_from_8k(pair, recwarn):
    from scipy.signal import resample_poly

    from benchmarks.metrics import NarrowbandWarning, is_narrowband

    reference, degraded = pair
    up_ref = resample_poly(resample_poly(reference, 1, 2), 2, 1)  # 16 k -> 8 k -> 16 k
    up_deg = resample_poly(resample_poly(degraded, 1, 2), 2, 1)
    assert not is_narrowband(reference, FS) and is_narrowband(up_ref, FS)
    with pytest.warns(NarrowbandWarning, match="narrow-band reference"):
        pesq_scores(up_ref, up_deg, fs=FS)
    pesq_scores(reference, degraded, fs=FS)  # the wide-band original: no label
    assert not [w for w in recwarn if issubclass(w.category, NarrowbandWarning)]
