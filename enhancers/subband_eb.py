"""Sub-band Elko beamformer: one NLMS beta per STFT bin (registry name ``"eb-subband"``).

Why per bin.  The exact response of ``y = cF - beta cB`` to a plane wave from ``theta``
(algorithms.md section 5, ``c = cos theta``) is proportional to
``sin(wT(1 + c)/2) - beta sin(wT(1 - c)/2)``, so a broadband interferer is nulled at every
frequency only if beta depends on frequency:

    beta_k(theta) = sin(w_k T (1 + c) / 2) / sin(w_k T (1 - c) / 2)        (1)

which lies in ``[0, 1]`` for every rear direction (``c <= 0``) and bin below Nyquist.  On
the WOLA filter bank (:mod:`enhancers.stft_stage`) bin ``k`` of frame ``l`` forms

    cF = X1 - e^{-j w_k T} X2,    cB = X2 - e^{-j w_k T} X1,    Y = cF - beta_k[l] cB

and beta is adapted per bin by normalised LMS on ``E|Y|^2`` (y with the old beta), once per frame::

    beta_k[l+1] = clip(beta_k[l] + mu Re(Y conj(cB)) / (P_B + eps P_1), 0, 1)
    P_B = lam P_B + (1 - lam) |cB|^2,   P_1 likewise for |X1|^2 (smoothed over frames, incl. frame l)

The clip keeps every bin's null in the rear half plane, so the frontal talker is never
the target of a null.  Adaptation gate (``adapt_gate_db``, as ``eb-gated``, here per bin):
frozen where ``10 log10(P_F / P_B) > min(floor, 0) + adapt_gate_db`` with one-pole smoothed
cardioid powers (``gate_lam``) and ``floor`` their running minimum over ``gate_floor_s``.

Real beta, not a complex weight (the decision the issue asks for).  With ideal (or
calibrated) microphones ``cF / cB`` of any plane wave is *real* (eq. 1), so a real beta
nulls it exactly: no degree of freedom is missing.  A rear-mic error ``r = g e^{j phi}``
makes the ratio complex, and then no real beta nulls the wave; a complex per-bin weight
``w`` would.  We keep the real beta and remove the mismatch in front of it with
:mod:`enhancers.mic_calibration` (``eb-robust``) because (a) ``[0, 1]`` is a simple,
verifiable constraint that keeps the look direction: for the look direction ``cB = 0``
exactly only with matched mics, and with a mismatch the complex weight's leakage
``w (1 - r) e^{-jwT} X1`` into the talker is of the same size as the mismatch it
compensates, i.e. a complex weight that nulls a mismatched interferer also changes the
talker's response by an unknown amount; (b) a complex weight has no half-plane
constraint of comparable simplicity (it can place a null on the frontal talker whenever
the talker leaks into the update); (c) a complex weight that absorbs the mismatch does
so for one direction only (the mismatch is not a direction), so it must re-adapt for
every source, while a calibrated pair serves every direction and the diffuse field.
What the real beta cannot do (tested): null a mismatched plane wave; the residual is then
the mismatch term, which is why ``eb-subband`` alone degrades with mismatched mics.

Equaliser: :func:`enhancers.eq.look_eq_gain` per bin (exact look-direction inverse,
``eq_max_gain_db`` cap; ``eq_noise_gain_db`` the noise-aware white-noise-gain bound;
``eq_highpass_hz``) times ``-j``: the look-direction response ``2j sin(wT) e^{-jwT}`` then
becomes the front mic delayed by ``T`` (not its 90-degree-shifted version), so the output
lines up with the reference at the declared latency plus ``T fs`` samples.  ``trace["beta"]``: ``(n_frames, n_bins)``, the beta applied to each frame.
Latency ``frame_len - 1`` samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.eq import look_eq_gain
from enhancers.stft_stage import (
    TINY,
    GateState,
    StftEnhancer,
    StftParams,
    bin_omega,
    gate_init,
    ratio_gate,
    smooth_frames,
)
from scenesim.errors import ParameterError
from scenesim.validate import check_range

__all__ = ["SubbandElkoBeamformer", "SubbandState", "closed_form_beta", "subband_beta_step"]


def closed_form_beta(theta_deg: float, omega_t) -> np.ndarray:
    """Per-bin beta nulling a plane wave from ``theta_deg`` exactly (eq. 1), ``omega_t = w T`` (rad).

    >>> round(float(closed_form_beta(120.0, 0.01)), 3)   # low frequency: (1 + c) / (1 - c) = 1/3
    0.333
    """
    c = math.cos(math.radians(theta_deg))
    wt = np.asarray(omega_t, dtype=float)
    return np.sin(wt * (1 + c) / 2) / np.where(np.sin(wt * (1 - c) / 2) == 0, np.inf, np.sin(wt * (1 - c) / 2))


@dataclass(frozen=True)
class SubbandState:
    """Per-bin adaptation state ``(K,)`` arrays, plus the gate's running-minimum history."""

    beta: np.ndarray
    p_b: np.ndarray
    p_1: np.ndarray
    gate: GateState


def subband_init(n_bins: int, beta0: float) -> SubbandState:
    z = np.zeros(n_bins)
    return SubbandState(beta=np.full(n_bins, float(beta0)), p_b=z, p_1=z, gate=gate_init(n_bins))


def _gate_frozen(cF, cB, state: SubbandState, *, gate_db: float, lam: float, n_window: int):
    """Per-bin gate: True where frozen; returns ``(frozen (F, K), state changes)``."""
    frozen, gate = ratio_gate(cF, cB, state=state.gate, gate_db=gate_db, lam=lam, n_window=n_window)
    return frozen, {"gate": gate}


def subband_beta_step(cF, cB, X1, state: SubbandState, *, mu: float, lam: float, eps: float,
                      gate_db: float | None = None, gate_lam: float | None = None, gate_window: int = 0):
    """Per-bin NLMS over the frames of one block (vectorised over bins; a loop over frames).

    Parameters
    ----------
    cF, cB, X1 : complex arrays (F, K)
        Forward/backward cardioids and the front mic's spectrum.
    state : SubbandState
    mu, lam, eps : NLMS step, power smoothing per frame, regularisation re ``P_1``.
    gate_db, gate_lam, gate_window : adaptation gate (None: off); window in frames (0: no floor).

    Returns
    -------
    betas : (F, K), the beta applied to each frame; new state.
    """
    F = cF.shape[0]
    if F == 0:
        return np.zeros(cF.shape), state
    bb = cB.real**2 + cB.imag**2
    pb = smooth_frames(bb, lam, state.p_b)
    p1 = smooth_frames(X1.real**2 + X1.imag**2, lam, state.p_1)
    den = pb + eps * p1 + TINY
    # beta + mu Re((cF - beta cB) cB*) / den = beta keep + gain
    gain = mu * (cF.real * cB.real + cF.imag * cB.imag) / den
    keep = 1.0 - mu * bb / den
    changes = {}
    if gate_db is not None:
        frozen, changes = _gate_frozen(cF, cB, state, gate_db=gate_db,
                                       lam=lam if gate_lam is None else gate_lam, n_window=gate_window)
        gain[frozen] = 0.0
        keep[frozen] = 1.0
    betas = np.empty(cF.shape)
    b = state.beta.copy()
    for i in range(F):  # the clip makes the recursion nonlinear: loop over frames, vectorised over bins
        betas[i] = b
        b *= keep[i]
        b += gain[i]
        np.clip(b, 0.0, 1.0, out=b)
    values = dict(vars(state))
    values.update(beta=b, p_b=pb[-1].copy(), p_1=p1[-1].copy(), **changes)
    return betas, SubbandState(**values)


@dataclass(frozen=True)
class SubbandEbParams(StftParams):
    """NLMS, gate and equaliser fields shared by ``eb-subband`` and ``eb-robust``."""

    mu: float = 0.1
    lam: float = 0.9
    eps: float = 1e-4
    beta0: float = 0.0
    adapt_gate_db: float | None = None
    gate_lam: float | None = None
    gate_floor_s: float = 0.0
    eq: bool = True
    eq_max_gain_db: float = 25.0
    eq_noise_gain_db: float | None = None
    eq_highpass_hz: float = 0.0

    def _check_subband(self):
        self._check_stft()
        check_range("mu", self.mu, 0.0, 2.0, lo_open=True, hi_open=True)
        check_range("lam", self.lam, 0.0, 1.0, hi_open=True)
        check_range("eps", self.eps, 0.0, 1.0)
        check_range("beta0", self.beta0, 0.0, 1.0)
        if self.adapt_gate_db is not None:
            check_range("adapt_gate_db", self.adapt_gate_db, -60.0, 60.0)
        if self.gate_lam is not None:
            check_range("gate_lam", self.gate_lam, 0.0, 1.0, hi_open=True)
        check_range("gate_floor_s", self.gate_floor_s, 0.0, 60.0)
        if not isinstance(self.eq, bool):
            raise ParameterError("eq", self.eq, "True or False")
        check_range("eq_max_gain_db", self.eq_max_gain_db, 0.0, 60.0)
        if self.eq_noise_gain_db is not None:
            check_range("eq_noise_gain_db", self.eq_noise_gain_db, -20.0, 60.0)
        check_range("eq_highpass_hz", self.eq_highpass_hz, 0.0, 1000.0)


class SubbandBase(StftEnhancer):
    """Sub-band EB on (possibly calibrated) spectra; subclasses may transform the rear mic first."""

    def _gate_window(self, fs: int) -> int:
        p = self.params
        return int(math.ceil(float(p.gate_floor_s) * fs / int(p.hop))) if p.gate_floor_s > 0 else 0

    def _cardioids(self, X1, X2, fs):
        ph = np.exp(-1j * bin_omega(int(self.params.frame_len)) * self.delay_samples(fs))
        return X1 - ph * X2, X2 - ph * X1

    def _eq(self, betas, fs):
        p = self.params
        if not p.eq:
            return np.ones_like(betas)
        n = int(p.frame_len)
        omega = bin_omega(n)
        g = look_eq_gain(betas, omega=omega, delay_samples=self.delay_samples(fs),
                         freqs_hz=omega / (2 * np.pi) * fs, max_gain_db=float(p.eq_max_gain_db),
                         noise_gain_db=None if p.eq_noise_gain_db is None else float(p.eq_noise_gain_db),
                         highpass_hz=float(p.eq_highpass_hz))
        # the look response is 2j sin(wT) e^{-jwT} X1: -j undoes the j (a 90 deg shift, which a
        # time-domain integrator undoes too), leaving the front mic delayed by T
        return -1j * g

    def _beamform(self, X1, X2, sub: SubbandState, fs: int):
        """``(Y (F, K), betas, eq gains, new state)`` for the frames of one block."""
        p = self.params
        cF, cB = self._cardioids(X1, X2, fs)
        betas, sub = subband_beta_step(
            cF, cB, X1, sub, mu=float(p.mu), lam=float(p.lam), eps=float(p.eps),
            gate_db=None if p.adapt_gate_db is None else float(p.adapt_gate_db),
            gate_lam=None if p.gate_lam is None else float(p.gate_lam), gate_window=self._gate_window(fs))
        G = self._eq(betas, fs)
        return G * (cF - betas * cB), betas, G, sub

    def _apply_beam(self, X1, X2, betas, G, fs):
        cF, cB = self._cardioids(X1, X2, fs)
        return G * (cF - betas * cB)


class SubbandElkoBeamformer(SubbandBase):
    """Elko's adaptive differential beamformer with one NLMS beta per STFT bin (see module docstring).

    Parameters (``SubbandElkoBeamformer.Params``)
    ---------------------------------------------
    spacing_m, c_mps : pair spacing (m) and speed of sound (m/s).
    frame_len, hop, window : WOLA filter bank (default 256 / 128 / Hamming = 16 ms, 50 % at 16 kHz).
    mu : NLMS step per frame, ``0 < mu < 2`` (default 0.1).
    lam : smoothing of the normalising powers per frame, ``[0, 1)`` (default 0.9 = 80 ms at 8 ms hops).
    eps : regularisation relative to the front-mic power (default 1e-4).
    beta0 : initial beta of every bin in ``[0, 1]`` (default 0: forward cardioid).
    adapt_gate_db, gate_lam, gate_floor_s : the per-bin adaptation gate (None = off, default).
    eq, eq_max_gain_db, eq_noise_gain_db, eq_highpass_hz : equaliser (:mod:`enhancers.eq`).

    Examples
    --------
    >>> import numpy as np, enhancers
    >>> e = enhancers.make("eb-subband")
    >>> y = e.process(np.random.default_rng(0).standard_normal((2, 16000)), 16000).output
    >>> y.shape
    (1, 16000)
    """

    name: ClassVar[str] = "eb-subband"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "Elko adaptive differential beamformer with one NLMS beta per STFT bin"

    @dataclass(frozen=True)
    class Params(SubbandEbParams):
        def __post_init__(self):
            self._check_subband()

    def _algo_init(self, fs, n_bins):
        return subband_init(n_bins, float(self.params.beta0))

    def _frames(self, X, algo, fs):
        Y, betas, G, algo = self._beamform(X[0], X[1], algo, fs)
        return Y[None], algo, {"beta": betas, "eq": G}

    def _apply(self, record, X, fs):
        return self._apply_beam(X[0], X[1], record["beta"], record["eq"], fs)[None]

    def _trace(self, record):
        return {"beta": record["beta"]}
