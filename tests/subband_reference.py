"""Slow, obviously correct references (loops over frames and bins) for the STFT-domain EB stages.

Written from the equations in the docstrings of :mod:`enhancers.beam.subband_eb` and
:mod:`enhancers.beam.mic_calibration`, without numpy vectorisation or scipy filters, so the
vectorised implementations can be checked against them to rounding.
"""

from __future__ import annotations

import math

import numpy as np


def gate_reference(cF, cB, *, gate_db: float, lam: float, n_window: int) -> np.ndarray:
    """Per-bin gate: frozen where 10 log10(P_F / P_B) > min(floor, 0) + gate_db (running minimum of the
    last ``n_window`` ratios, 0: no floor); smoothed powers P = lam P + (1 - lam) |c|^2 from 0."""
    F, K = cF.shape
    frozen = np.zeros((F, K), dtype=bool)
    for k in range(K):
        pf = pb = 0.0
        ratios = []
        for f in range(F):
            pf = lam * pf + (1 - lam) * abs(cF[f, k]) ** 2
            pb = lam * pb + (1 - lam) * abs(cB[f, k]) ** 2
            r = 10 * math.log10((pf + 1e-300) / (pb + 1e-300))
            ratios.append(r)
            if n_window == 0:
                ref = 0.0
            else:
                ref = min(min(ratios[-n_window:]), 0.0)
            frozen[f, k] = r > ref + gate_db
    return frozen


def subband_beta_reference(cF, cB, X1, *, mu: float, lam: float, eps: float, beta0: float = 0.0,
                           gate_db: float | None = None, gate_lam: float | None = None,
                           n_window: int = 0) -> np.ndarray:
    """Per-bin NLMS: beta[f] is applied to frame f; then
    beta <- clip(beta + mu Re((cF - beta cB) conj(cB)) / (P_B + eps P_1), 0, 1) unless frozen,
    with P_B, P_1 one-pole smoothed (lam) including frame f, starting from 0."""
    F, K = cF.shape
    frozen = (np.zeros((F, K), dtype=bool) if gate_db is None else
              gate_reference(cF, cB, gate_db=gate_db, lam=lam if gate_lam is None else gate_lam, n_window=n_window))
    betas = np.zeros((F, K))
    for k in range(K):
        beta, pb, p1 = beta0, 0.0, 0.0
        for f in range(F):
            betas[f, k] = beta
            pb = lam * pb + (1 - lam) * abs(cB[f, k]) ** 2
            p1 = lam * p1 + (1 - lam) * abs(X1[f, k]) ** 2
            if frozen[f, k]:
                continue
            y = cF[f, k] - beta * cB[f, k]
            beta += mu * (y * np.conj(cB[f, k])).real / (pb + eps * p1 + 1e-300)
            beta = min(max(beta, 0.0), 1.0)
    return betas


def _gate_on_powers(eF, eB, *, gate_db: float, lam: float, n_window: int) -> np.ndarray:
    """``gate_reference`` on given powers (F, K): frozen where the smoothed ratio exceeds min(floor, 0) + gate_db."""
    F, K = eF.shape
    frozen = np.zeros((F, K), dtype=bool)
    for k in range(K):
        pf = pb = 0.0
        ratios = []
        for f in range(F):
            pf = lam * pf + (1 - lam) * eF[f, k]
            pb = lam * pb + (1 - lam) * eB[f, k]
            ratios.append(10 * math.log10((pf + 1e-300) / (pb + 1e-300)))
            ref = min(min(ratios[-n_window:]), 0.0) if n_window else 0.0
            frozen[f, k] = ratios[-1] > ref + gate_db
    return frozen


def calibration_reference(X1, X2, *, delay: float, frame_len: int, band: tuple[int, int], tau_frames: float,
                          lam_gate: float, n_window: int, freeze_db: float, freeze_band_db: float,
                          every: int, smooth_bins: int, smooth_frac: float, max_gain_db: float,
                          max_phase_deg: float, min_coherence: float, phase_leak: float):
    """``r_hat (F, K)`` of ``mic-calibration`` by loops over frames and bins (band = first, last bin).

    Freeze: per bin from the cardioid powers of bins k-3, k-2, k+2, k+3; for the band from its sums
    without bins k-1..k+1.  Averages S11, S22, S21 move by max(1/n, 1 - exp(-1/tau_frames)) at the
    bin's n-th unfrozen frame, not at all where frozen.
    Every ``every``-th frame: slope = lag-one phase refined by the weighted fit a + b k + c/k (normal
    equations with the 1e-9 ridge of the implementation, columns 1, k/k_hi, k_lo/k), clipped to
    2 pi delay / N; S21 derotated; all three averaged over k +- max(smooth_bins, round(smooth_frac k));
    gain sqrt(S22/S11) and phase clipped; the phase kept from the previous estimate where the averaged
    coherence |S21| / sqrt(S11 S22) < min_coherence, times phase_leak per update.
    """
    F, K = X1.shape
    lo, hi = band
    cF = np.empty((F, K), dtype=complex)
    cB = np.empty((F, K), dtype=complex)
    for k in range(K):
        ph = np.exp(-1j * 2 * np.pi * k / frame_len * delay)
        cF[:, k] = X1[:, k] - ph * X2[:, k]
        cB[:, k] = X2[:, k] - ph * X1[:, k]
    eF, eB = np.abs(cF) ** 2, np.abs(cB) ** 2
    nF, nB = np.zeros((F, K)), np.zeros((F, K))
    bF, bB = np.zeros((F, K)), np.zeros((F, K))
    for f in range(F):
        for k in range(K):
            for o in (-3, -2, 2, 3):
                if 0 <= k + o < K:
                    nF[f, k] += eF[f, k + o]
                    nB[f, k] += eB[f, k + o]
            for j in range(lo, hi + 1):
                if abs(j - k) > 1:
                    bF[f, k] += eF[f, j]
                    bB[f, k] += eB[f, j]
    rule = dict(lam=lam_gate, n_window=n_window)
    frozen = (_gate_on_powers(nF, nB, gate_db=freeze_db, **rule)
              | _gate_on_powers(bF, bB, gate_db=freeze_band_db, **rule))
    s = np.zeros((3, K), dtype=complex)
    counts = np.zeros(K)
    r_hat = np.ones((F, K), dtype=complex)
    current = np.ones(K, dtype=complex)
    for f in range(F):
        for k in range(K):
            if not frozen[f, k]:
                counts[k] += 1
                step = max(1 / counts[k], 1 - math.exp(-1 / tau_frames))
                for i, v in enumerate((abs(X1[f, k]) ** 2, abs(X2[f, k]) ** 2, X2[f, k] * np.conj(X1[f, k]))):
                    s[i, k] += step * (v - s[i, k])
        if f % every == 0:
            current = _estimate_reference(s, lo, hi, delay, frame_len, smooth_bins, smooth_frac, max_gain_db,
                                          max_phase_deg, min_coherence, np.angle(current), phase_leak)
        r_hat[f] = current
    return r_hat, frozen


def _estimate_reference(s, lo, hi, delay, frame_len, smooth_bins, smooth_frac, max_gain_db, max_phase_deg,
                        min_coherence, prev_phase, phase_leak):
    K = s.shape[1]
    s11, s22, s21 = s[0].real, s[1].real, s[2]
    lag = sum(s21[k + 1] * np.conj(s21[k]) for k in range(lo, hi))
    b0 = np.angle(lag)
    wmax = max(abs(s21[k]) for k in range(lo, hi + 1))
    M = np.zeros((3, 3))
    rhs = np.zeros(3)
    for k in range(lo, hi + 1):
        col = np.array([1.0, k / hi, lo / k])
        w = abs(s21[k]) / (wmax + 1e-300)
        psi = np.angle(s21[k] * np.exp(-1j * b0 * k))
        M += w * np.outer(col, col)
        rhs += w * col * psi
    coef = np.linalg.solve(M + 1e-9 * np.eye(3), rhs)
    max_slope = 2 * np.pi * delay / frame_len
    slope = min(max(b0 + coef[1] / hi, -max_slope), max_slope)
    out = np.empty(K, dtype=complex)
    for k in range(K):
        m = max(smooth_bins, int(np.round(smooth_frac * k)))
        js = range(max(k - m, 0), min(k + m + 1, K))
        d = sum(s21[j] * np.exp(-1j * slope * j) for j in js) / len(js)
        a11 = sum(s11[j] for j in js) / len(js)
        a22 = sum(s22[j] for j in js) / len(js)
        g = min(max(10 * math.log10((a22 + 1e-300) / (a11 + 1e-300)), -max_gain_db), max_gain_db)
        phi = min(max(np.angle(d), -math.radians(max_phase_deg)), math.radians(max_phase_deg))
        if abs(d) < min_coherence * math.sqrt(a11 * a22):  # too little coherence: the old phase, fading
            phi = prev_phase[k] * phase_leak
        out[k] = 10 ** (g / 20) * np.exp(1j * phi)
    return out
