"""Slow, obviously correct references (loops over frames and bins) for the STFT-domain EB stages.

Written from the equations in the docstrings of :mod:`enhancers.subband_eb` and
:mod:`enhancers.mic_calibration`, without numpy vectorisation or scipy filters, so the
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
