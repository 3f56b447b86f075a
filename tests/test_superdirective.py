"""Superdirective (diffuse-field MVDR with a WNG floor): directivity and WNG vs the closed form,
the endfire hypercardioid limit, the WNG floor, and the look direction passing undistorted."""

from __future__ import annotations

import numpy as np
import pytest
from signals import C_MPS, FS, SPACING_M, lowpass_noise, plane_wave_pair

from enhancers.beam.superdirective import (
    Superdirective,
    diffuse_coherence,
    directivity_db,
    steering_vector,
    superdirective_weights,
    wng_db,
)
from scenesim.errors import ParameterError

FREQS = np.fft.rfftfreq(256, 1 / FS)[1:]  # the filter bank's bins but DC (Gamma is singular there)


def _reference_mvdr(f, mu, look_deg=0.0):
    """Slow reference: per frequency, Gamma and d written out, MVDR by np.linalg.solve."""
    w = np.empty((f.size, 2), dtype=complex)
    for i, (fi, m) in enumerate(zip(f, mu)):
        g = np.sin(2 * np.pi * fi * SPACING_M / C_MPS) / (2 * np.pi * fi * SPACING_M / C_MPS)
        gamma = np.array([[1.0, g], [g, 1.0]])
        tau = SPACING_M * np.cos(np.radians(look_deg)) / C_MPS
        d = np.array([1.0, np.exp(-2j * np.pi * fi * tau)])
        a = np.linalg.solve(gamma + m * np.eye(2), d)
        w[i] = a / np.conj(d.conj() @ a)
    return w


def _closed_form(w, f, look_deg=0.0):
    """DI = |w^H d|^2 / (w^H Gamma w), WNG = |w^H d|^2 / (w^H w), in dB, with explicit matrices."""
    di, wng = [], []
    for wi, fi in zip(w, f):
        x = 2 * fi * SPACING_M / C_MPS
        gamma = np.array([[1.0, np.sinc(x)], [np.sinc(x), 1.0]])
        d = np.array([1.0, np.exp(-2j * np.pi * fi * SPACING_M * np.cos(np.radians(look_deg)) / C_MPS)])
        num = abs(wi.conj() @ d) ** 2
        di.append(10 * np.log10(num / np.real(wi.conj() @ gamma @ wi)))
        wng.append(10 * np.log10(num / np.real(wi.conj() @ wi)))
    return np.array(di), np.array(wng)


@pytest.mark.parametrize("look_deg", [0.0, 60.0])
def test_weights_di_and_wng_match_the_closed_form(look_deg):
    """Oracle: MVDR solved per bin with np.linalg.solve at the same loading, and DI/WNG from the
    matrices written out (tolerance 1e-9 on weights, 1e-9 dB on DI/WNG)."""
    w, mu = superdirective_weights(FREQS, spacing_m=SPACING_M, c_mps=C_MPS, look_az_deg=look_deg, wng_min_db=-10.0)
    np.testing.assert_allclose(w, _reference_mvdr(FREQS, mu, look_deg), rtol=0, atol=1e-9)
    di, wng = _closed_form(w, FREQS, look_deg)
    d = steering_vector(FREQS, spacing_m=SPACING_M, c_mps=C_MPS, look_az_deg=look_deg)
    g = diffuse_coherence(FREQS, spacing_m=SPACING_M, c_mps=C_MPS)
    np.testing.assert_allclose(directivity_db(w, d, g), di, rtol=0, atol=1e-9)
    np.testing.assert_allclose(wng_db(w, d), wng, rtol=0, atol=1e-9)


def test_wng_floor_is_met_with_the_smallest_loading():
    """WNG >= -10 dB in every bin; where loading was needed the floor is met with equality (to
    1e-6 dB: minimal loading, since WNG grows monotonically with mu); unloaded bins keep the
    unconstrained weights."""
    w, mu = superdirective_weights(FREQS, spacing_m=SPACING_M, c_mps=C_MPS, wng_min_db=-10.0)
    d = steering_vector(FREQS, spacing_m=SPACING_M, c_mps=C_MPS)
    wng = wng_db(w, d)
    assert np.all(wng >= -10.0 - 1e-9)
    loaded = mu > 1e-12
    assert loaded[0] and not loaded[-1]  # 62.5 Hz needs loading at d = 2.14 cm, 8 kHz does not
    np.testing.assert_allclose(wng[loaded], -10.0, atol=1e-6)
    w0, _ = superdirective_weights(FREQS, spacing_m=SPACING_M, c_mps=C_MPS, wng_min_db=None)
    np.testing.assert_allclose(w[~loaded], w0[~loaded], atol=1e-12)


def test_unconstrained_low_frequency_limit_is_the_endfire_hypercardioid():
    """Closed form: two-mic endfire superdirectivity tends to DI = 10 log10 4 = 6.02 dB as f -> 0
    (tolerance 0.01 dB at 50 Hz, d = 2.14 cm); with the -10 dB WNG floor DI drops there."""
    f = np.array([50.0, 100.0])
    w, _ = superdirective_weights(f, spacing_m=SPACING_M, c_mps=C_MPS, wng_min_db=None)
    di, _ = _closed_form(w, f)
    np.testing.assert_allclose(di, 10 * np.log10(4.0), atol=0.01)
    wc, _ = superdirective_weights(f, spacing_m=SPACING_M, c_mps=C_MPS, wng_min_db=-10.0)
    assert np.all(_closed_form(wc, f)[0] < 2.0)


def test_look_direction_passes_as_the_reference_mic(rng):
    """A band-limited (100 Hz - 7 kHz) plane wave from endfire comes out as p1 delayed by the declared
    latency; measured residual -45.4 dB, bound -40 dB (frame-wise filtering of an inter-mic delay is
    not exact at frame edges).  Oracle: exact FFT-domain plane wave (tests/signals.py)."""
    s = lowpass_noise(3 * FS, cutoff_hz=7000.0, lo_hz=100.0, rng=rng)
    x = plane_wave_pair(s)
    e = Superdirective()
    y = e.process(x, FS).output[0]
    L = e.tags.latency_samples
    err = y[L + FS:] - x[0, FS:-L]
    assert 10 * np.log10(np.mean(err**2) / np.mean(x[0, FS:-L] ** 2)) <= -40.0


@pytest.mark.parametrize(("kwargs", "name"), [({"wng_min_db": 4.0}, "wng_min_db"), ({"spacing_m": 0.0}, "spacing_m"),
                                              ({"look_az_deg": float("nan")}, "look_az_deg")])
def test_bad_params_name_the_field(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        Superdirective(**kwargs)
