"""The ``"hall"`` noise field (machines in a reverberant factory hall) and noise-type variants.

Oracles: Sabine's critical distance ``r_c = sqrt(A / (16 pi))`` with ``A = 0.161 V / T60`` (beyond it the
reverberant energy exceeds the direct sound's); a variant ``<type>-<name>`` plays exactly ``<type>``'s noise.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from data_recipes import open_data
from scenesim.room.cache import cached_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import NoiseSource, Scene, render_images
from scenesim.scene.geometry import MicPair
from scenesim.scene.noise_hall import (
    HALL_DIMS_M,
    HALL_MIN_DISTANCE_M,
    HALL_PAIR_M,
    HALL_RT60_S,
    hall_noise,
    hall_positions,
)

FS = 16000


def test_machines_are_beyond_the_critical_distance_so_the_hall_dominates():
    """Critical distance of the hall (Sabine): r_c = sqrt(0.161 V / (16 pi T60)) = 1.97 m < 3 m, the machines'
    minimum distance; so every machine's RIR has more energy after its direct sound (+-1 ms) than in it."""
    V = float(np.prod(HALL_DIMS_M))
    r_c = np.sqrt(0.161 * V / (16 * np.pi * HALL_RT60_S))
    assert r_c < HALL_MIN_DISTANCE_M
    hall = ShoeBox(HALL_DIMS_M, rt60_s=HALL_RT60_S)
    mics = MicPair(HALL_PAIR_M).positions_m
    p = hall_positions(3, 1)[0]
    h = cached_rir(hall, tuple(p), mics, fs=FS, method="hybrid")[0]
    k = int(np.argmax(np.abs(h)))
    direct = np.sum(h[max(0, k - 16):k + 16] ** 2)
    assert np.sum(h**2) - direct > direct


def test_hall_field_renders_through_the_scene():
    """A scene with a "hall" noise (the talker in the scene's free field) renders a finite, non-zero
    (2, n) noise image."""
    n = FS // 2
    scene = Scene(fs=FS, noises=(NoiseSource(field="hall", n_sources=2),), seed=4, far_field=True)
    rng = np.random.default_rng(0)
    images = render_images(scene, rng.standard_normal(n), [rng.standard_normal(n)])
    img = images.noise_image
    assert img.shape == (2, n) and np.all(np.isfinite(img)) and np.any(img)


def test_noise_variant_plays_its_type():
    """``factory-hall`` is the ``factory`` noise (same seed, same samples): only its field differs."""
    ds = open_data(None, fs=FS)
    a = ds.noise("factory-hall", 0.25, seed=2).signal
    b = ds.noise("factory", 0.25, seed=2).signal
    np.testing.assert_array_equal(a, b)


def test_hall_noise_is_linear_in_the_machines():
    """hall_noise of two machines == the sum of each alone at the same places (one convolution each)."""
    rng = np.random.default_rng(1)
    sig = rng.standard_normal((2, 4000))
    pair = MicPair()
    both = hall_noise(sig, pair, fs=FS, seed=5)
    first = hall_noise(np.stack([sig[0], 0 * sig[1]]), pair, fs=FS, seed=5)
    second = hall_noise(np.stack([0 * sig[0], sig[1]]), pair, fs=FS, seed=5)
    np.testing.assert_allclose(both, first + second, rtol=0, atol=1e-12)


def test_the_pre_run_data_check_accepts_a_variant_and_refuses_an_unknown_noise():
    # Regression: the runner's check before any work compared noise names with the data's
    # types and refused 'factory-hall', so the full `phone` preset exited 2 at once (a
    # `--limit` that skipped the variant hid it).  One rule now (DataSource.plays) for both.
    from benchmarks.run.runner import _check_data
    from benchmarks.run.sweep import load_sweep
    from data_recipes import open_data
    from scenesim.errors import ConfigError

    conditions = [c for c in load_sweep("phone").conditions() if c.noise == "factory-hall"][:1]
    assert conditions
    _check_data(conditions, None)  # no error
    assert open_data(None).plays("factory-hall") == "factory"
    assert open_data(None).plays("factory") == "factory" and open_data(None).plays("hall-factory") is None
    bad = [dataclasses.replace(conditions[0], noise="nonsense-hall")]
    with pytest.raises(ConfigError, match="'nonsense-hall'"):
        _check_data(bad, None)
