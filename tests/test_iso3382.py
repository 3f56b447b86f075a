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


def _double_slope_rt(t_early, t_late, late_db, lo_db, hi_db):
    """Decay time fitted over [lo_db, hi_db] of the closed-form Schroeder curve of the energy
    envelope 10^(-6 t / T_e) + 10^(late_db / 10) 10^(-6 t / T_l) (t >= 0), on a 0.1 ms grid."""
    t = np.arange(0, 6.0, 1e-4)
    k_e, k_l = 6 * math.log(10) / t_early, 6 * math.log(10) / t_late
    s = np.exp(-k_e * t) / k_e + 10 ** (late_db / 10) * np.exp(-k_l * t) / k_l
    level = 10 * np.log10(s / s[0])
    sel = (level <= hi_db) & (level >= lo_db)
    return -60.0 / np.polyfit(t[sel], level[sel], 1)[0]


def test_two_slope_octaves_give_edt_below_t30_and_their_band_means():
    # Each octave's tone decays fast (T_e) then slowly (T_l, 20 dB down): EDT follows the
    # closed-form Schroeder fit over 0..-10 dB, T30 over -5..-35 dB (5 %: the cos^2 ripple and
    # the neighbours' leakage).  EDT_mid / EDT_speech are the means of the EDTs (not the T30s).
    centers = (500.0, 1000.0, 2000.0)
    early, late = (0.25, 0.2, 0.15), (1.2, 1.0, 0.8)
    t = np.arange(int(3.0 * FS)) / FS
    h = sum(np.cos(2 * np.pi * f * t + 0.3) * np.sqrt(10.0 ** (-6 * t / e) + 10.0 ** (-2 - 6 * t / L))
            for f, e, L in zip(centers, early, late))
    p = room_parameters(h, FS, direct_sample=0, centers_hz=centers)
    edt = [_double_slope_rt(e, L, -20.0, -10.0, 0.0) for e, L in zip(early, late)]
    t30 = [_double_slope_rt(e, L, -20.0, -35.0, -5.0) for e, L in zip(early, late)]
    np.testing.assert_allclose(p["edt_s"], edt, rtol=0.05)
    np.testing.assert_allclose(p["t30_s"], t30, rtol=0.05)
    assert max(p["edt_s"] / p["t30_s"]) < 0.6
    assert p["edt_mid_s"] == pytest.approx(np.mean(p["edt_s"][:2]), rel=1e-12)
    assert p["edt_speech_s"] == pytest.approx(np.mean(p["edt_s"]), rel=1e-12)
    assert p["t_speech_s"] == pytest.approx(np.mean(p["t30_s"]), rel=1e-12)
    # A band mean whose octaves were not measured is NaN, not the mean of what is there.
    q = room_parameters(h, FS, direct_sample=0, centers_hz=(500.0, 1000.0))
    assert math.isnan(q["t_speech_s"]) and math.isnan(q["edt_speech_s"]) and not math.isnan(q["t_mid_s"])


def test_onset_ignores_pre_arrival_noise_and_is_not_the_peak():
    # ISO 3382-1 A.3.4: the onset is the first sample within 20 dB of the peak.  Noise 40 dB
    # down before the direct sound must not start it, and a stronger later reflection (the
    # peak) must not either: direct at 300 (amplitude 0.5, -6 dB), reflection at 340 (1.0).
    rng = np.random.default_rng(4)
    h = _exp_decay(0.4, 2 * int(0.4 * FS), onset=300) * 0.01
    h[:300] = 0.01 * rng.standard_normal(300)
    h[300] += 0.5
    h[340] += 1.0
    assert onset_sample(h) == 300
    p = room_parameters(h, FS, centers_hz=(1000.0,))
    assert p["onset_sample"] == 300
    # Closed form: C50 counts [300, 1100) against the rest.
    e = h**2
    assert p["c50_db"] == pytest.approx(10 * math.log10(e[300:1100].sum() / e[1100:].sum()), abs=1e-9)


def test_a_fractional_direct_arrival_starts_at_its_peak_sample():
    # A direct sound between samples (a windowed sinc at 200.4): with h_direct the onset is the
    # peak of the direct path (200, the nearest sample), and C50 is the closed form of the
    # exponential from there (0.05 dB: half a sample of decay and the sinc's spread).
    n = np.arange(-32, 33)
    pulse = np.sinc(n - 0.4) * np.hanning(n.size)
    hd = np.zeros(8 * FS // 10)
    hd[200 + n] = pulse
    tail = _exp_decay(0.5, hd.size - 201, onset=201) * 0.05
    h = hd + tail
    p = room_parameters(h, FS, h_direct=hd, centers_hz=(1000.0,))
    assert p["onset_sample"] == 200
    e = h**2
    assert p["c50_db"] == pytest.approx(10 * math.log10(e[200:1000].sum() / e[1000:].sum()), abs=1e-9)


def test_diffuse_targets_at_half_the_critical_distance():
    # r = r_c / 2: D / R = 4, so the exact DRR is 20 log10 2 = 6.02 dB; C(t_e) =
    # 10 log10((4 + 1 - q) / q), q = 10^(-6 t_e / T) (closed forms, 1e-9 dB).
    t, v = 0.6, 80.0
    rc = 0.057 * math.sqrt(v / t)
    p = diffuse_field_parameters(t, rc / 2, v)
    assert p["critical_distance_m"] == pytest.approx(rc, rel=1e-12)
    assert p["drr_exact_db"] == pytest.approx(20 * math.log10(2), abs=1e-9)
    for key, te in (("c50_db", 0.05), ("drr_windowed_db", 0.0025)):
        q = 10 ** (-6 * te / t)
        assert p[key] == pytest.approx(10 * math.log10((5 - q) / q), abs=1e-9)
    assert p["d50"] == pytest.approx(1 / (1 + 10 ** (-p["c50_db"] / 10)), rel=1e-12)


@pytest.mark.parametrize(("fs", "nan_top"), [(11025, True), (12000, False), (16000, False)])
def test_the_top_octave_is_nan_only_when_it_reaches_nyquist(fs, nan_top):
    # The 8 kHz octave's lower edge is 8000 / sqrt 2 = 5657 Hz: at or above 0.499 fs (fs <=
    # 11337 Hz) the band does not exist and is NaN; at 12 kHz it is measured.  4 kHz always is.
    t = np.arange(int(1.5 * fs)) / fs
    rng = np.random.default_rng(1)
    h = rng.standard_normal(t.size) * 10.0 ** (-3.0 * t / 0.4)
    p = room_parameters(h, fs, direct_sample=0, centers_hz=(4000.0, 8000.0))
    assert not math.isnan(p["t30_s"][0])
    assert math.isnan(p["t30_s"][1]) == nan_top
    assert math.isnan(p["edt_s"][1]) == nan_top
