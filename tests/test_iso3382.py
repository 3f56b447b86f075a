"""ISO 3382-1 parameters on synthetic exponential decays, against their closed forms."""

import math

import numpy as np
import pytest

from scenesim.room.iso3382 import (
    clarity_db,
    definition_d50,
    diffuse_clarity_db,
    diffuse_field_parameters,
    onset_sample,
    room_parameters,
    windowed_drr_db,
)

FS = 16000


def _exp_decay(rt60_s: float, n: int, onset: int = 0) -> np.ndarray:
    """``h[n] = 10^(-3 (n - onset) / (fs T))``: energy falls 60 dB in T (closed-form RT60 = T)."""
    h = np.zeros(onset + n)
    h[onset:] = 10.0 ** (-3.0 * np.arange(n) / (FS * rt60_s))
    return h


def test_c50_d50_closed_form_after_a_delay():
    # Energy ratio per sample r = 10^(-6/(fs T)); the first N = 800 samples against the rest:
    # C50 = 10 log10((1 - r^N) / r^N) (infinite geometric sums; 5 T long, truncation < 1e-20).
    t, onset = 0.5, 321
    h = _exp_decay(t, 5 * int(t * FS), onset)
    rn = 10.0 ** (-6.0 * 800 / (FS * t))
    p = room_parameters(h, FS, direct_sample=onset, centers_hz=(1000.0,))
    assert p["c50_db"] == pytest.approx(10 * math.log10((1 - rn) / rn), abs=1e-9)
    assert p["d50"] == pytest.approx(1 - rn, abs=1e-12)
    assert onset_sample(h) == onset


def test_c50_of_an_exponential_equals_the_diffuse_field_far_away():
    # Far beyond r_c the direct sound vanishes: Sabine's C50 is that of a pure exponential decay.
    t = 0.8
    h = _exp_decay(t, 5 * int(t * FS))
    far = diffuse_clarity_db(1e4, 1.0, t, 0.05)
    assert clarity_db(h, FS, onset=0) == pytest.approx(far, abs=1e-3)


@pytest.mark.parametrize("rt60", [0.3, 0.7, 1.5])
def test_broadband_t30_and_edt_of_an_exponential(rt60):
    # A pure exponential's Schroeder curve is a straight line: T30 = EDT = T (1e-3 relative:
    # the geometric tail beyond 4 T is below -240 dB).
    from scenesim.room.rt60 import measure_rt60

    h = _exp_decay(rt60, 4 * int(rt60 * FS), onset=100)
    onset = onset_sample(h)
    assert measure_rt60(h[onset:], FS, method="T30") == pytest.approx(rt60, rel=1e-3)
    assert measure_rt60(h[onset:], FS, method="EDT") == pytest.approx(rt60, rel=1e-3)


def test_per_octave_t30_edt_and_t_mid_of_damped_tones():
    # One exponentially damped cosine at each octave centre, each with its own decay: every
    # octave's T30 and EDT measure its own tone's T (3 %: leakage of the neighbours through
    # the 3rd-order Butterworth pair and the cos^2 ripple of the Schroeder curve).
    centers = (250.0, 500.0, 1000.0, 2000.0, 4000.0)
    decay = (1.2, 0.9, 0.5, 0.7, 0.4)
    t = np.arange(int(2.5 * FS)) / FS
    h = sum(np.cos(2 * np.pi * f * t + 0.3) * 10.0 ** (-3.0 * t / d) for f, d in zip(centers, decay))
    p = room_parameters(h, FS, direct_sample=0, centers_hz=centers)
    np.testing.assert_allclose(p["t30_s"], decay, rtol=0.03)
    np.testing.assert_allclose(p["edt_s"], decay, rtol=0.03)
    assert p["t_mid_s"] == pytest.approx(np.mean(p["t30_s"][1:3]), rel=1e-12)
    assert p["t_mid_s"] == pytest.approx(0.7, rel=0.03)
    assert p["t_speech_s"] == pytest.approx(0.7, rel=0.03)


def test_windowed_and_exact_drr_closed_form():
    # Direct impulse A at n_d, a reflection 1 ms later (inside +-2.5 ms), then an exponential
    # tail from n_d + 10 ms: the windowed DRR counts A^2 + b^2, the exact one A^2 only.
    t, n_d, a, b = 0.6, 500, 2.0, 0.7
    h = np.zeros(FS)
    h[n_d] = a
    h[n_d + 16] = b
    tail = _exp_decay(t, FS - n_d - 160)
    h[n_d + 160 :] = 0.2 * tail
    tail_e = float(np.sum((0.2 * tail) ** 2))
    hd = np.zeros(n_d + 1)
    hd[n_d] = a
    p = room_parameters(h, FS, h_direct=hd, centers_hz=(1000.0,))
    assert p["drr_windowed_db"] == pytest.approx(10 * math.log10((a * a + b * b) / tail_e), abs=1e-9)
    assert p["drr_exact_db"] == pytest.approx(10 * math.log10(a * a / (b * b + tail_e)), abs=1e-9)
    assert windowed_drr_db(h, FS) == pytest.approx(p["drr_windowed_db"], abs=1e-12)


def test_diffuse_targets_are_the_same_quantities():
    # At the critical distance D = R: exact DRR 0 dB; the windowed DRR adds the reverberant
    # energy of the first 2.5 ms to the direct: 10 log10((2 - q) / q), q = 10^(-6 * 0.0025 / T).
    t, vol = 0.7, 80.0
    rc = 0.057 * math.sqrt(vol / t)
    p = diffuse_field_parameters(t, rc, vol)
    q = 10.0 ** (-6 * 0.0025 / t)
    assert p["drr_exact_db"] == pytest.approx(0.0, abs=1e-12)
    assert p["drr_windowed_db"] == pytest.approx(10 * math.log10((2 - q) / q), abs=1e-12)
    assert p["d50"] == pytest.approx(definition_d50(p["c50_db"]), abs=1e-15)
    assert p["t_mid_s"] == p["edt_s"] == t
