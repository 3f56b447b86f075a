"""WOLA filter bank: perfect reconstruction, streaming == batch, agreement with scipy's ShortTimeFFT."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import ShortTimeFFT

from enhancers.core.filterbank import FilterBank, frame_len_for
from scenesim.errors import ParameterError


def _stream(fb: FilterBank, x: np.ndarray, block: int, gain=None) -> np.ndarray:
    state = fb.init_state(x.shape[0])
    outs = []
    for i in range(0, x.shape[-1], block):
        b = x[:, i:i + block]
        X, state = fb.analysis_step(b, state)
        if gain is not None:
            X = X * gain
        y, state = fb.synthesis_step(X, b.shape[-1], state)
        outs.append(y)
    return np.concatenate(outs, axis=-1)


@pytest.mark.parametrize("frame_len,hop", [(256, 128), (512, 128), (400, 160), (256, 256)])
@pytest.mark.parametrize("block", [1, 128, 97, 10_000])
def test_unit_gains_reconstruct_input_after_latency(frame_len, hop, block, rng):
    """Oracle: identity.  Output = input delayed by N - 1 samples, to 1e-12 (rounding only)."""
    fb = FilterBank(frame_len=frame_len, hop=hop)
    x = rng.standard_normal((2, 3001))
    y = _stream(fb, x, block)
    L = fb.latency_samples
    assert y.shape == x.shape
    np.testing.assert_allclose(y[:, L:], x[:, : x.shape[-1] - L], rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[:, :L], 0.0, atol=1e-12)


def test_streaming_equals_batch_with_gains(rng):
    """Any per-frame linear operation: block outputs concatenated == one-shot output (to 1e-12)."""
    fb = FilterBank()
    x = rng.standard_normal((1, 2000))
    gain = rng.uniform(0, 2, fb.n_bins)
    ref = _stream(fb, x, x.shape[-1], gain)
    for block in (1, 128, 97):
        np.testing.assert_allclose(_stream(fb, x, block, gain), ref, rtol=0, atol=1e-12)


def test_dual_window_partition_of_unity():
    """sum_k w_a[n - kR] w_s[n - kR] = 1 for every n (the perfect-reconstruction condition), to 1e-14."""
    fb = FilterBank()
    prod = fb.analysis_window * fb.synthesis_window
    np.testing.assert_allclose(prod[:128] + prod[128:], 1.0, atol=1e-14)


def test_analysis_equals_scipy_short_time_fft(rng):
    """Outside oracle: scipy.signal.ShortTimeFFT with the same window and hop, phase_shift=None.

    scipy's slice p is centred on sample p*hop, i.e. spans [p R - N/2, p R + N/2 - 1]; our frame l
    spans [l R + R - N, l R + R - 1]: identical for N = 2R, so frame l == slice l (tolerance 1e-12).
    """
    fb = FilterBank()
    x = rng.standard_normal(5000)
    X = fb.analyze(x[None])[0]
    stft = ShortTimeFFT(fb.analysis_window, hop=fb.hop, fs=16000, fft_mode="onesided", phase_shift=None)
    Xs = stft.stft(x)[:, : X.shape[0]].T
    np.testing.assert_allclose(X, Xs, rtol=0, atol=1e-12)


def test_parseval_per_frame(rng):
    """Parseval: sum |X_k|^2 (one-sided, doubled interior) / N == sum (w x)^2 per frame, to 1e-10 relative."""
    fb = FilterBank()
    x = rng.standard_normal((1, 1280))
    X = fb.analyze(x)[0]
    energy = (np.abs(X[:, 0]) ** 2 + np.abs(X[:, -1]) ** 2 + 2 * np.sum(np.abs(X[:, 1:-1]) ** 2, axis=1)) / 256
    frames = np.stack([x[0, max(0, l * 128 - 128): l * 128 + 128] for l in range(1, X.shape[0])])
    direct = np.sum((frames * fb.analysis_window) ** 2, axis=1)
    np.testing.assert_allclose(energy[1:], direct, rtol=1e-10)


def test_frame_len_for_16khz_is_256():
    assert frame_len_for(16000) == 256 and frame_len_for(8000) == 128


@pytest.mark.parametrize("kwargs,name", [({"hop": 0}, "hop"), ({"frame_len": 1}, "frame_len"),
                                         ({"window": "nope"}, "window"), ({"window": 3.0}, "window"), ({"hop": 300}, "hop")])
def test_bad_configuration_names_the_parameter(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        FilterBank(**kwargs)
