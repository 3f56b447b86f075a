"""The fast paths of the metric layer against the slow computations they replace."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.metrics import speech as M
from scenesim.scene.mixing import bandlimit


def _slow_band_snr(s, n, fs, band):
    # The former definition: full-length brick-wall band-pass (scenesim.scene.mixing.bandlimit), then powers.
    return M.snr_db(bandlimit(s, fs, band), bandlimit(n, fs, band))


@pytest.mark.parametrize(("size", "tol_db"), [(96000, 1e-9), (128000, 1e-9), (127745, 1e-2), (95873, 1e-2)])
def test_band_snr_matches_the_full_length_brick_wall(size, tol_db):
    # Oracle: the unpadded FFT band-pass.  Fast lengths (no padding) agree to rounding (1e-9 dB);
    # padded lengths cut the band edges on a finer grid: within 0.01 dB on coloured noise.
    rng = np.random.default_rng(size)
    s = rng.standard_normal(size)
    s = s + 0.01 * np.cumsum(s)  # low-frequency heavy: much of its power outside the band
    n = 0.3 * rng.standard_normal(size)
    want = _slow_band_snr(s, n, 16000, (100, 7000))
    assert M.band_snr_db(s, n, fs=16000, band_hz=(100, 7000)) == pytest.approx(want, abs=tol_db)


def test_narrowband_check_is_cached_per_signal_and_recomputed_for_another():
    rng = np.random.default_rng(1)
    wide = rng.standard_normal(16000)
    from scipy.signal import resample_poly

    narrow = resample_poly(rng.standard_normal(8000), 2, 1)  # upsampled from 8 kHz: narrow-band
    assert M.is_narrowband(narrow, 16000) and not M.is_narrowband(wide, 16000)
    for x in (wide, narrow, wide.copy(), narrow.copy()):
        assert M._is_narrowband_cached(x, 16000) == M.is_narrowband(x, 16000)


@pytest.mark.parametrize(("na", "nb", "max_lag", "delay"), [(5000, 5000, 300, 37), (4000, 5000, 800, -250),
                                                          (6001, 3000, 50, 0), (3000, 6001, 2999, 1200)])
def test_estimate_lag_equals_the_direct_correlation(na, nb, max_lag, delay):
    # Oracle: the direct sum over every lag (np.correlate, no FFT, no wrap-around possible).
    rng = np.random.default_rng(na + nb)
    b = rng.standard_normal(nb)
    a = np.roll(np.pad(b, (0, max(0, na - nb)))[:na], delay) + 0.5 * rng.standard_normal(na)
    full = np.correlate(a, b, mode="full")  # full[k + nb - 1] = sum_n a[n + k] b[n]
    lags = np.arange(-max_lag, max_lag + 1)
    lags = lags[(lags < na) & (lags > -nb)]
    want = int(lags[np.argmax(np.abs(full[lags + nb - 1]))])
    assert M.estimate_lag(a, b, max_lag=max_lag) == want


def test_estimate_lag_has_no_wrap_around_peak():
    # a's last 50 samples copy b's first 50: only a circular correlation sees a match at lag -50
    # (the true lag of that copy, 950, is outside the search); the direct sum is the oracle.
    rng = np.random.default_rng(5)
    b = np.zeros(1000)
    b[:100] = rng.standard_normal(100)
    a = np.zeros(1000)
    a[20:120] = b[:100]  # the real match at lag +20
    a[950:] = 3 * b[:50]  # a stronger circular-only match at lag -50
    full = np.correlate(a, b, mode="full")
    lags = np.arange(-100, 101)
    want = int(lags[np.argmax(np.abs(full[lags + 999]))])
    assert want == 20
    assert M.estimate_lag(a, b, max_lag=100) == want
