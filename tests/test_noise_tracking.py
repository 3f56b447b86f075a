"""Martin 1994 / Martin 2001 noise trackers: slow reference, calibration, bias and tracking oracles.

Oracle for accuracy: the simulation knows the true noise PSD.  For unit-variance white noise the
expected periodogram of a Hamming-windowed frame is ``sum(w^2)`` in every bin; for coloured
noise made by FFT shaping with ``|H(f)|^2`` it is ``|H(f_k)|^2 sum(w^2)`` up to window smearing
(< 0.1 dB above 250 Hz for the 1/f shape used here).
"""

from __future__ import annotations

import numpy as np
import pytest

from enhancers.core.filterbank import FilterBank
from enhancers.single.noise_tracking import (
    MS2001Config,
    calibrate_omin,
    ms1994_init,
    ms1994_step,
    ms2001_init,
    ms2001_step,
    track_ms1994,
    track_ms2001,
)

FS = 16000
FB = FilterBank()
W2 = float(np.sum(FB.analysis_window**2))
ALPHA, N_SUB, SUB_LEN = 0.9, 8, 24  # the SpectralSubtraction defaults


def ms1994_reference(S, *, alpha, n_sub, sub_len):
    """Slow, obviously correct Martin 1994 minimum search: one frame at a time, a Python list as ring."""
    P = S[0].copy()
    actmin = np.full(S.shape[1], np.inf)
    ring = [np.full(S.shape[1], np.inf) for _ in range(n_sub)]
    out = []
    for l in range(S.shape[0]):
        P = alpha * P + (1 - alpha) * S[l]
        actmin = np.minimum(actmin, P)
        if (l + 1) % sub_len == 0:
            ring = ring[1:] + [actmin]
            actmin = np.full(S.shape[1], np.inf)
            pmin = np.min(ring, axis=0)
        else:
            pmin = np.minimum(np.min(ring, axis=0), actmin)
        out.append(pmin)
    return np.array(out)


def _periodogram(x):
    X = FB.analyze(x[None])[0]
    return np.abs(X) ** 2


def _pink(n, rng):
    """1/f-shaped noise by FFT shaping; returns (signal, |H(f)|^2 function)."""
    f = np.fft.rfftfreq(n, 1 / FS)
    shape = 1.0 / np.maximum(f, 50.0)
    X = np.fft.rfft(rng.standard_normal(n)) * np.sqrt(shape)
    x = np.fft.irfft(X, n=n)
    # E|X_m|^2 of the shaped noise per DFT bin of the long signal is n*|H|^2: variance = mean(|H|^2) over bins
    return x, lambda fk: 1.0 / np.maximum(fk, 50.0)


def test_ms1994_matches_slow_reference_in_any_chunking(rng):
    """Oracle: the per-frame reference above; equal to 1e-12 (relative) for chunk sizes 1, 7, all."""
    S = rng.exponential(size=(300, 9))
    ref = ms1994_reference(S, alpha=ALPHA, n_sub=4, sub_len=5)
    for chunk in (1, 7, 300):
        state, parts = ms1994_init(9, n_sub=4), []
        for i in range(0, 300, chunk):
            _, pmin, state = ms1994_step(S[i:i + chunk], state, alpha=ALPHA, sub_len=5)
            parts.append(pmin)
        np.testing.assert_allclose(np.concatenate(parts), ref, rtol=1e-12)


def test_omin_calibration_reproducible_and_near_martin():
    """omin = 1/E[Pmin]: two independent seeds agree to 1 % (Monte Carlo error), and the value lies in
    1.2..1.5 for alpha .95 and D = 64..128 frames (algorithms.md: ~1.3)."""
    a = calibrate_omin(alpha=0.95, n_sub=8, sub_len=12)
    b = calibrate_omin(alpha=0.95, n_sub=8, sub_len=12, seed=7)
    assert a is calibrate_omin(alpha=0.95, n_sub=8, sub_len=12)  # cached
    np.testing.assert_allclose(a[1:-1], b[1:-1], rtol=0.01)
    assert 1.2 < a[64] < 1.5
    assert 1.2 < calibrate_omin(alpha=0.95, n_sub=8, sub_len=16)[64] < 1.5


def _bin_error_db(Pn, true_k, start):
    """Mean over bins of the dB error of the time-averaged estimate."""
    return float(np.mean(10 * np.log10(Pn[start:].mean(axis=0) / true_k)))


@pytest.mark.parametrize("colour", ["white", "pink"])
def test_trackers_unbiased_on_stationary_noise(colour, rng):
    """After the initial window (2 s) both trackers are within +-1 dB of the true PSD (bin average)."""
    n = 7 * FS
    if colour == "white":
        x = 0.3 * rng.standard_normal(n)
        psd = lambda fk: np.full_like(fk, 0.09)  # noqa: E731
    else:
        x, shape = _pink(n, rng)
        var_scale = np.var(x) / np.mean(shape(np.fft.rfftfreq(n, 1 / FS)[1:]))
        psd = lambda fk: var_scale * shape(fk)  # noqa: E731
    S = _periodogram(x)
    fk = np.fft.rfftfreq(256, 1 / FS)
    keep = slice(5, -1)  # 312 Hz .. below Nyquist: away from the 50 Hz knee and the real DC/Nyquist bins
    true_k = psd(fk)[keep] * W2
    start = 2 * FS // 128
    omin = calibrate_omin(alpha=ALPHA, n_sub=N_SUB, sub_len=SUB_LEN)
    e94 = _bin_error_db(track_ms1994(S, alpha=ALPHA, n_sub=N_SUB, sub_len=SUB_LEN, omin=omin)[:, keep], true_k, start)
    e01 = _bin_error_db(track_ms2001(S, frame_step_s=128 / FS)[:, keep], true_k, start)
    assert abs(e94) < 1.0, e94
    assert abs(e01) < 1.0, e01


@pytest.mark.parametrize("tracker", ["ms1994", "ms2001"])
def test_noise_step_tracked_within_two_seconds(tracker, rng):
    """+10 dB white-noise step at 3 s: from 2.0 s after the step to the end (1 s more), every frame's
    bin-averaged estimate is within 1.5 dB of the new true level."""
    n_pre, n_post = 3 * FS, 3 * FS
    x = np.concatenate([0.1 * rng.standard_normal(n_pre), np.sqrt(10) * 0.1 * rng.standard_normal(n_post)])
    S = _periodogram(x)
    if tracker == "ms1994":
        Pn = track_ms1994(S, alpha=ALPHA, n_sub=N_SUB, sub_len=SUB_LEN,
                          omin=calibrate_omin(alpha=ALPHA, n_sub=N_SUB, sub_len=SUB_LEN))
    else:
        Pn = track_ms2001(S, frame_step_s=128 / FS)
    true = 0.1 * W2  # new variance 0.1 times sum(w^2)
    err = 10 * np.log10(Pn[:, 1:-1].mean(axis=1) / true)
    step_frame = n_pre // 128
    after = err[step_frame + 2 * FS // 128:]
    assert np.all(np.abs(after) < 1.5), (after.min(), after.max())


def test_ms2001_streaming_equals_batch(rng):
    """Chunked steps reproduce the one-shot run exactly (same arithmetic order), to 1e-12 relative."""
    S = rng.exponential(size=(200, 17))
    cfg = MS2001Config(frame_step_s=0.008)
    _, ref, _ = ms2001_step(S, ms2001_init(), cfg)
    state, parts = ms2001_init(), []
    for i in range(0, 200, 13):
        _, pn, state = ms2001_step(S[i:i + 13], state, cfg)
        parts.append(pn)
    np.testing.assert_allclose(np.concatenate(parts), ref, rtol=1e-12)


def test_trackers_finite_on_silence():
    """All-zero periodograms: estimates are exactly zero, never NaN (floored divisions)."""
    S = np.zeros((100, 129))
    assert np.all(track_ms2001(S, frame_step_s=0.008) == 0)
    assert np.all(track_ms1994(S, alpha=ALPHA, n_sub=4, sub_len=4, omin=1.3) == 0)
