"""The rear/front response ratio of two first-order high-passed mics, and its weighted fit (``model="hp1"``).

Sensor model (algorithms.md section 4b): each mic has a sensitivity and a first-order high-pass
``H_i(f) = j f / (f_ci + j f)``, the rear one optionally a constant phase, so the rear/front ratio is

    r(f) = g e^{j phi0} (f_c1 + j f) / (f_c2 + j f)

with 4 real parameters, stored as ``theta = (ln g, phi0 (rad), ln f_c1, ln f_c2)`` (logarithms: the
gain and the corners stay positive, and the fit's steps are relative).  :func:`fit_hp1` fits them to
per-bin measurements of ``ln r`` (real part: log gain, imaginary part: phase), plus a fifth, nuisance
parameter ``theta[4]``: a phase ``theta[4] f / 1 kHz`` proportional to frequency (what a propagation
slope removed beforehand left over -- a pure delay between the mics is not in the sensor model, so it
is never part of ``r``; with it a wrong slope does not leak into ``phi0`` and the corners), by
weighted least squares -- a few Gauss-Newton steps from a warm start, with a weak prior towards ``HP1_PRIOR`` (equal
100 Hz corners, ``r = 1``) that decides what the data cannot: every parameter before any data, and
the common corner when the corners are equal (then ``r`` does not depend on it).

Why (issue 16): a per-bin estimate pools a few cells, so the talker x noise cross terms in the
learned cells move it between the runs on ``s + n`` and ``s - n``; 4 parameters fitted over ~60
bins pool ~15x more cells per parameter, and the estimate cannot take a shape the sensors do not have.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["HP1_PRIOR", "fit_hp1", "hp1_log_response"]

#: ``theta`` of the prior: unit gain, no phase, both corners at 100 Hz (``r(f) = 1``), no residual slope.
HP1_PRIOR = np.array([0.0, 0.0, math.log(100.0), math.log(100.0), 0.0])
#: the prior's weights, inverse variances like the fit's (one cell measured over one frame weighs ~2): a
#: sensitivity within ~2 dB, a constant phase within ~10 deg, corners within a factor ~2, a residual slope
#: within ~1 rad/kHz -- a few cells' worth: negligible once cells are learned, decisive where the data says nothing.
PRIOR_WEIGHT = np.array([20.0, 30.0, 2.0, 2.0, 1.0])
# corners are kept in 5 Hz .. 2 kHz, and a step changes one by at most a factor e (a far guess cannot jump)
_LOG_FC_RANGE = (math.log(5.0), math.log(2000.0))
_MAX_STEP = 1.0


def hp1_log_response(f_hz: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``ln r(f)`` of the model, complex like ``f_hz (K,)`` (Hz); ``theta = (ln g, phi0, ln fc1, ln fc2, ...)``
    (a fifth entry, the fit's nuisance slope, is not part of ``r``).

    >>> import numpy as np
    >>> theta = np.array([np.log(10 ** (1 / 20)), np.radians(5.0), np.log(80.0), np.log(120.0)])
    >>> r = np.exp(hp1_log_response(np.array([100.0, 8000.0]), theta))
    >>> [round(float(x), 2) for x in (20 * np.log10(abs(r[0])), np.degrees(np.angle(r[0])))]
    [-0.73, 16.53]
    >>> [round(float(x), 2) for x in (20 * np.log10(abs(r[1])), np.degrees(np.angle(r[1])))]
    [1.0, 5.29]
    """
    fc1, fc2 = math.exp(theta[2]), math.exp(theta[3])
    return theta[0] + 1j * theta[1] + np.log(fc1 + 1j * f_hz) - np.log(fc2 + 1j * f_hz)


def _robust(w: np.ndarray, e: np.ndarray, floor: float | None) -> np.ndarray:
    """Weights ``w (K,)`` times Cauchy's ``1 / (1 + (e / s)^2)`` for residuals ``e (K,)``, ``s = max(3 / sqrt(w),
    floor)`` (None: ``w`` unchanged): a bin far off the model (a talker's harmonic) counts less."""
    if floor is None:
        return w
    s = np.maximum(3.0 / np.sqrt(np.maximum(w, 1e-30)), floor)
    return w / (1.0 + (e / s) ** 2)


def _normal_equations(f_hz, log_r, w_gain, w_phase, theta, robust=None):
    """Gauss-Newton's ``(J^T W J (5, 5), J^T W e (5,))`` at ``theta (5,)`` (the data part, no prior; ``robust``:
    the Cauchy weights' floor, :func:`_robust`)."""
    fc1, fc2 = math.exp(theta[2]), math.exp(theta[3])
    err = log_r - hp1_log_response(f_hz, theta) - 1j * theta[4] * f_hz / 1000.0
    err = err.real + 1j * np.angle(np.exp(1j * err.imag))  # the phase residual wrapped to (-pi, pi]
    J = np.stack([np.ones_like(f_hz, dtype=complex), np.full(f_hz.shape, 1j),
                  fc1 / (fc1 + 1j * f_hz), -fc2 / (fc2 + 1j * f_hz), 1j * f_hz / 1000.0])  # d / d theta, (5, K)
    w_gain, w_phase = _robust(w_gain, err.real, robust), _robust(w_phase, err.imag, robust)
    A = (J.real * w_gain) @ J.real.T + (J.imag * w_phase) @ J.imag.T
    b = (J.real * w_gain) @ err.real + (J.imag * w_phase) @ err.imag
    return A, b


def fit_hp1(f_hz: np.ndarray, log_r: np.ndarray, w_gain: np.ndarray, w_phase: np.ndarray,
            theta0: np.ndarray | None = None, *, n_iter: int = 3, max_slope: float = 1.0,
            prior_scale: float = 1.0, robust: float | None = None) -> np.ndarray:
    """Fit ``theta`` (5,) -- :func:`hp1_log_response`'s 4 and the nuisance slope -- to ``log_r (K,)``
    measured at ``f_hz (K,)`` (Hz).

    Minimises ``sum_k w_gain[k] Re(e_k)^2 + w_phase[k] Im(e_k)^2 + s sum_i PRIOR_WEIGHT[i] (theta - HP1_PRIOR)[i]^2``
    (``s = prior_scale``: a larger one shrinks towards ``r = 1`` until the weights outgrow it),
    ``e_k = log_r[k] - ln r(f_k) - j theta[4] f_k / 1 kHz`` (phase wrapped), by ``n_iter`` Gauss-Newton
    steps from ``theta0``
    (the previous fit; default the prior).  Weights ``(K,)`` >= 0: the inverse variances of the log gain
    and of the phase (0: the bin says nothing about it).  Kept physical: ``|phi0| <= pi / 2``, corners in
    5 Hz-2 kHz, ``|theta[4]| <= max_slope`` (rad per kHz: the propagation phase a pair can have; with
    phase residuals wrapped, a free slope can lock onto an alias).  ``robust`` (None: off): each step
    reweights the bins by Cauchy's ``1 / (1 + (e / s)^2)``, ``s = max(3 / sqrt(w), robust)`` (natural log
    units: 0.05 is 0.43 dB or 2.9 deg), so a few bins far off the model pull it little.

    >>> import numpy as np
    >>> f = np.arange(2, 65) * 62.5
    >>> truth = np.array([0.1, 0.05, np.log(60.0), np.log(140.0), 0.2])
    >>> w = np.full(f.shape, 1e6)
    >>> est = fit_hp1(f, hp1_log_response(f, truth) + 0.2j * f / 1000, w, w, n_iter=20)
    >>> bool(np.allclose(est, truth, atol=1e-3))
    True
    """
    theta = HP1_PRIOR.copy() if theta0 is None else np.array(theta0, dtype=float)
    for _ in range(int(n_iter)):
        A, b = _normal_equations(f_hz, log_r, w_gain, w_phase, theta, robust)
        A = A + np.diag(prior_scale * PRIOR_WEIGHT)
        b = b - prior_scale * PRIOR_WEIGHT * (theta - HP1_PRIOR)
        step = np.linalg.solve(A, b)
        slope = float(np.clip(theta[4] + step[4], -max_slope, max_slope))
        if slope != theta[4] + step[4]:  # at its bound: the slope fixed there, the others solved for that
            step[4] = slope - theta[4]
            step[:4] = np.linalg.solve(A[:4, :4], b[:4] - A[:4, 4] * step[4])
        step[2:4] = np.clip(step[2:4], -_MAX_STEP, _MAX_STEP)
        theta = theta + step
        theta[1] = np.clip(theta[1], -math.pi / 2, math.pi / 2)
        theta[2:4] = np.clip(theta[2:4], *_LOG_FC_RANGE)
    return theta
