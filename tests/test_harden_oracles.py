"""Issue 15 part 5: headline values against oracles independent of the code under test."""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.reverb_parts import rir_acoustics

FS = 16000


def _double_slope(t1: float, t2: float, a2: float, length_s: float) -> np.ndarray:
    """h(t) = exp(-k1 t) + a2 exp(-k2 t), k = 3 ln(10) / T (amplitude decays 60 dB in T)."""
    t = np.arange(int(length_s * FS)) / FS
    k1, k2 = 3 * np.log(10) / t1, 3 * np.log(10) / t2
    return np.exp(-k1 * t) + a2 * np.exp(-k2 * t)


def _closed_form_rt(t1, t2, a2, length_s, lo_db, hi_db) -> float:
    """RT from the closed-form Schroeder integral of :func:`_double_slope` (E(t) = int_t^L h^2),
    a least-squares line over the samples between ``hi_db`` and ``lo_db``: -60 / slope."""
    t = np.arange(int(length_s * FS)) / FS
    k1, k2 = 3 * np.log(10) / t1, 3 * np.log(10) / t2
    L = t[-1] + 1.0 / FS

    def F(x):  # antiderivative of h^2, up to sign
        return (np.exp(-2 * k1 * x) / (2 * k1) + 2 * a2 * np.exp(-(k1 + k2) * x) / (k1 + k2)
                + a2**2 * np.exp(-2 * k2 * x) / (2 * k2))

    energy = F(t) - F(L)
    level = 10 * np.log10(energy / energy[0])
    sel = (level <= hi_db) & (level >= lo_db)
    slope = np.polyfit(t[sel], level[sel], 1)[0]
    return -60.0 / slope


def test_edt_and_t30_of_a_double_slope_decay_match_the_closed_form_and_differ():
    # A fast early decay (T 0.3 s) over a slow weak tail (T 1.5 s, -14 dB): EDT follows the
    # early part, T30 the tail, so EDT is well below T30 (a copy of T30 in edt_s fails).
    # Oracle: the closed-form Schroeder integral, fitted here; tolerance 3 % (sampled sums).
    h = _double_slope(0.3, 1.5, 0.2, 2.5)
    got = rir_acoustics(h, h[:1], fs=FS, cut_sample=int(0.05 * FS))
    edt = _closed_form_rt(0.3, 1.5, 0.2, 2.5, -10.0, 0.0)
    t30 = _closed_form_rt(0.3, 1.5, 0.2, 2.5, -35.0, -5.0)
    assert edt < 0.7 * t30
    assert got["edt_s"] == pytest.approx(edt, rel=0.03)
    assert got["t30_s"] == pytest.approx(t30, rel=0.03)
