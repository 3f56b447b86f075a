"""The compiled frame loops of the noise-statistics stage against their numpy references (slow reference).

Tolerance: relative 1e-12 of the largest value (the same operations in the same order; only ``1 / n``
times versus division differs, ~1e-16 per frame).
"""

from __future__ import annotations

import numpy as np
import pytest

from enhancers.beam.noise_stats import NoiseStatsConfig, noise_stats_init, noise_stats_step
from enhancers.single.spp import SppConfig, spp_init, spp_step


def _frames(seed, n_frames=600, n_bins=33):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((2, n_frames, n_bins)) + 1j * rng.standard_normal((2, n_frames, n_bins))
    X[:, 200:320, 5:12] *= 30.0  # a talker-like burst 30 dB up in some bins: the SPP moves
    return X


def _close(a, b):
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.max(np.abs(b)))


@pytest.mark.parametrize("split", [None, 137])
def test_spp_kernel_equals_the_numpy_reference(split):
    S = np.abs(_frames(0)[0]) ** 2
    c = SppConfig()
    P_ref, s_ref, _ = spp_step(S, spp_init(S.shape[1]), c)
    if split is None:
        P, s, _ = spp_step(S, spp_init(S.shape[1]), c, kernel=True)
    else:  # streaming through the kernel: two calls carry the state
        P1, s1, st = spp_step(S[:split], spp_init(S.shape[1]), c, kernel=True)
        P2, s2, _ = spp_step(S[split:], st, c, kernel=True)
        P, s = np.concatenate([P1, P2]), np.concatenate([s1, s2])
    _close(P, P_ref)
    _close(s, s_ref)


def test_covariance_kernel_equals_the_numpy_reference_in_one_call_and_in_blocks():
    X = _frames(1)
    c = NoiseStatsConfig(spp="single")
    ref, _ = noise_stats_step(X, noise_stats_init(X.shape[2]), c)
    state, parts = noise_stats_init(X.shape[2]), []
    for lo, hi in ((0, 1), (1, 250), (250, 600)):
        out, state = noise_stats_step(X[:, lo:hi], state, c, kernel=True)
        parts.append(out)
    for name in ("yy", "vv", "p", "n_vv"):
        _close(np.concatenate([getattr(p, name) for p in parts]), getattr(ref, name))


@pytest.mark.parametrize("spp", ["single", "mean"])
def test_skipping_the_noisy_average_leaves_the_noise_statistics_unchanged(spp):
    """``noisy=False`` (a caller that reads only the noise covariance): the same ``vv``, ``p``, ``n_vv`` as
    the reference, in blocks too; no ``yy`` frames, and the noisy average's state untouched."""
    X = _frames(2)
    c = NoiseStatsConfig(spp=spp)
    ref, _ = noise_stats_step(X, noise_stats_init(X.shape[2]), c)
    state, parts = noise_stats_init(X.shape[2]), []
    for lo, hi in ((0, 97), (97, 600)):
        out, state = noise_stats_step(X[:, lo:hi], state, c, kernel=True, noisy=False)
        parts.append(out)
        assert out.yy.shape[0] == 0
    for name in ("vv", "p", "n_vv"):
        _close(np.concatenate([getattr(p, name) for p in parts]), getattr(ref, name))
    assert not np.any(state.r_yy) and not np.any(state.n_yy)
