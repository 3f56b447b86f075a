"""Elko's adaptive first-order differential beamformer and fixed cardioid/hypercardioid (algorithms.md section 5).

``y[n] = cF[n] - beta[n] cB[n]`` (:mod:`enhancers.beam.differential`), followed by the optional
look-direction equaliser.  ``beta`` minimises ``E[y^2]`` by NLMS and is clipped to
``[0, 1]`` (null in the rear half plane) at every update:

* ``update="block"`` (default): ``beta`` is constant over blocks of ``block_len`` samples
  aligned to the stream start; at the end of each block
  ``beta += mu sum(y cB) / (sum(cB^2) + eps sum(p1^2))`` with ``y`` computed with the old beta.
* ``update="sample"``: ``beta += mu y[n] cB[n] / (P_B[n] + eps P_1[n])``,
  ``P_B[n] = lam P_B[n-1] + (1 - lam) cB[n]^2`` (``P_1`` likewise for the front mic).

``eps`` is relative to the front-mic power so the update is scale invariant and silence
gives zero (never NaN).

Adaptation gate (opt-in, ``adapt_gate_db``; off by default = the thesis/Elko behaviour):
minimising ``E[y^2]`` lets a frontal talker pull beta towards 1 (``y = cF - beta cB`` shrinks
for it), away from the noise null ("target leakage"; measured with a talker at 45 deg and
noise at 180 deg).  Every source in the rear half plane has ``P_F <= P_B`` in every band,
so the update is frozen (block variant: per block, decided at its last sample; sample
variant: per sample) where ``r = 10 log10(P_F / P_B) > min(floor, 0) + adapt_gate_db``, with
``P_F``, ``P_B`` the one-pole smoothed cardioid powers (``gate_lam``, default ``lam``) and
``floor`` the running minimum of ``r`` over the last ``gate_floor_s`` seconds (0: no floor,
reference 0 dB).  The floor follows the rear noise's own ratio (very low at 180 deg, where
cF nulls it; -9.5 dB at 120 deg at low frequencies; 0 dB at 90/270 deg), so speech far
below the noise already freezes the update.  Registered with defaults as ``"eb-gated"`` (:class:`GatedElkoBeamformer`).
The gate only decides when beta moves; ``trace["beta"]`` and replay are unchanged.

Given the beta sequence, the output is linear in (p1, p2):
``Result.replay`` re-applies the same beta sequence and equaliser to a component.
``trace["beta"]``: the beta used for each output sample, ``(n,)``.

Latency: ``fd_half_len`` samples (both branches are delayed by it so a fractional ``T fs``
can use a centred windowed sinc; whole-number ``T fs`` uses exact shifts).

Streaming: blocks of up to :data:`enhancers.kernels.stream.MAX_BLOCK` samples run the compiled
:func:`enhancers.kernels.stream.differential_block` (the same arithmetic, one call per block,
the state updated in place); longer blocks and batch run the numpy step below, the reference.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.ndimage import minimum_filter1d
from scipy.signal import lfilter

from enhancers.beam.differential import DifferentialFilters, branch_signals, design_filters
from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_int, check_positive, check_range

__all__ = ["ElkoBeamformer", "FixedCardioid", "FixedHypercardioid", "GatedElkoBeamformer"]

_TINY = 1e-300


@dataclass(frozen=True)
class _DifferentialParams(Params):
    spacing_m: float = 0.0214
    c_mps: float = 343.0
    eq: bool = True
    eq_fc_hz: float = 70.0
    eq_hf: float | None = None
    fd_half_len: int = 16
    t_samples: float | None = None

    def _check_common(self):
        check_positive("spacing_m", self.spacing_m)
        check_positive("c_mps", self.c_mps)
        if not isinstance(self.eq, bool):
            raise ParameterError("eq", self.eq, "True or False")
        check_range("eq_fc_hz", self.eq_fc_hz, 0.0, 1000.0, lo_open=True)
        if self.eq_hf is not None:
            check_range("eq_hf", self.eq_hf, 0.0, 1.0, hi_open=True)
        check_int("fd_half_len", self.fd_half_len, minimum=1, maximum=1024)
        if self.t_samples is not None:
            check_range("t_samples", self.t_samples, 0.0, 64.0, lo_open=True)


@dataclass
class _DiffState:  # the numpy step replaces it, the compiled step updates it in place
    fs: int
    history: np.ndarray          # (2, filters.history) last input samples
    beta: float
    eq_zi: np.ndarray | None     # (2,) lfilter state of the equaliser
    # block variant: partial sums of the open adaptation block
    phase: int = 0
    s_fb: float = 0.0
    s_bb: float = 0.0
    s_11: float = 0.0
    # sample variant: smoothed powers
    p_b: float = 0.0
    p_1: float = 0.0
    # adaptation gate (both variants): smoothed forward/backward cardioid powers
    g_f: float = 0.0
    g_b: float = 0.0
    g_hist: np.ndarray | None = None  # last gate ratios (dB) of the running-minimum window


class _DifferentialBase(Enhancer):
    """Shared streaming/batch path; subclasses define the beta sequence (``_betas``)."""

    Params: ClassVar[type[Params]] = _DifferentialParams

    @functools.cached_property
    def tags(self) -> Tags:  # params are frozen, so the tags never change (cached: read per block)
        return Tags(channels_in=2, channels_out=1, needs_geometry=True, streaming=True,
                    latency_samples=int(self.params.fd_half_len))

    def filters(self, fs: int) -> DifferentialFilters:
        """Branch filters and equaliser at ``fs`` (cached)."""
        p = self.params
        # t_samples fixes the internal delay in samples (the thesis: one sample) whatever the spacing
        spacing = float(p.spacing_m) if p.t_samples is None else float(p.t_samples) * float(p.c_mps) / int(fs)
        return design_filters(spacing_m=spacing, c_mps=float(p.c_mps), fs=int(fs),
                              fd_half_len=int(p.fd_half_len), eq=bool(p.eq), eq_fc_hz=float(p.eq_fc_hz),
                              eq_hf=None if p.eq_hf is None else float(p.eq_hf))

    def _initial_beta(self) -> float:  # pragma: no cover
        raise NotImplementedError

    def _betas(self, cF, cB, p1, state: _DiffState) -> tuple[np.ndarray, _DiffState]:  # pragma: no cover
        raise NotImplementedError

    def _init_state(self, fs: int) -> _DiffState:
        f = self.filters(fs)
        return _DiffState(fs=fs, history=np.zeros((2, f.history)), beta=self._initial_beta(),
                          eq_zi=None if f.eq_b is None else np.zeros(len(f.eq_a) - 1))

    def _step(self, block: np.ndarray, state: _DiffState):
        f = self.filters(state.fs)
        n = block.shape[-1]
        ext = np.concatenate([state.history, block], axis=-1)
        new_hist = ext[:, ext.shape[-1] - f.history:].copy()
        if n == 0:
            return np.zeros((1, 0)), _replace(state, history=new_hist), np.zeros(0)
        cF, cB, p1 = branch_signals(ext, f, n)
        betas, state = self._betas(cF, cB, p1, state)
        y = cF - betas * cB
        zi = state.eq_zi
        if f.eq_b is not None:
            y, zi = lfilter(f.eq_b, f.eq_a, y, zi=zi)
        return y[None, :], _replace(state, history=new_hist, eq_zi=zi), betas

    def _process_block(self, block, state):
        import enhancers.kernels.stream as sk  # lazy: numba's import is only paid when streaming

        args = _kernel_args(type(self), self.params, state.fs) if 0 < block.shape[-1] <= sk.MAX_BLOCK else None
        if args is None:
            out, new, _ = self._step(block, state)
            return out, new
        return self._compiled_step(sk, block, state, args), state

    def _compiled_step(self, sk, block, state: _DiffState, args) -> np.ndarray:
        """The block through :func:`enhancers.kernels.stream.differential_block`; ``state`` updated in place."""
        h, lat, eq_b, eq_a, pp, mode, gate, n_window = args
        zi = _EMPTY if state.eq_zi is None else state.eq_zi
        if state.g_hist is None and gate and n_window > 1:
            state.g_hist = np.full(n_window - 1, np.inf)
        ghist = _EMPTY if state.g_hist is None else state.g_hist
        sc = np.array([state.beta, state.phase, state.s_fb, state.s_bb, state.s_11, state.g_f, state.g_b,
                       state.p_b, state.p_1])
        ext = sk.extend(state.history, block)
        y = sk.differential_block(ext, state.history, h, lat, eq_b, eq_a, zi, sc, pp, mode, gate, ghist, n_window)
        (state.beta, phase, state.s_fb, state.s_bb, state.s_11, state.g_f, state.g_b, state.p_b,
         state.p_1) = sc.tolist()
        state.phase = int(phase)
        return y[None, :]

    def _process(self, x: np.ndarray, fs: int) -> Result:
        out, _, betas = self._step(x, self._init_state(fs))
        f = self.filters(fs)
        n = x.shape[-1]
        beta_seq = betas.copy()
        beta_seq.setflags(write=False)

        def replay(component) -> np.ndarray:
            comp = check_component(component, (2, n))
            ext = np.concatenate([np.zeros((2, f.history)), comp], axis=-1)
            cF, cB, _ = branch_signals(ext, f, n)
            y = cF - beta_seq * cB
            if f.eq_b is not None:
                y, _ = lfilter(f.eq_b, f.eq_a, y, zi=np.zeros(len(f.eq_a) - 1))
            return y[None, :]

        return Result(output=out, trace={"beta": beta_seq}, _replay=replay)


_EMPTY = np.zeros(0)  # stands for "no equaliser" / "no gate window" in the compiled step (never written)


@functools.lru_cache(maxsize=64)
def _kernel_args(cls, params, fs: int):
    """Arguments of :func:`enhancers.kernels.stream.differential_block` for ``cls(params)`` at ``fs``.

    ``(h, latency, eq_b, eq_a, pp, mode, gate, n_window)`` with the equaliser's numerator padded
    to the denominator's length, as ``lfilter`` pads it; None where the compiled step does not
    cover the configuration (the sample variant with a gate window: its running minimum per
    sample is left to the numpy step).
    """
    import enhancers.kernels.stream as sk

    e = cls(params)
    f = e.filters(fs)
    p = params
    if issubclass(cls, _FixedBase):
        mode, gate, n_window = sk.FIXED, False, 0
        pp = np.zeros(8)
    else:
        mode = sk.BLOCK_NLMS if p.update == "block" else sk.SAMPLE_NLMS
        gate = p.adapt_gate_db is not None
        per = int(p.block_len) if p.update == "block" else 1
        n_window = int(math.ceil(float(p.gate_floor_s) * fs / per)) if p.gate_floor_s > 0 else 0
        if gate and mode == sk.SAMPLE_NLMS:
            return None
        g = float(p.lam if p.gate_lam is None else p.gate_lam)
        pp = np.array([p.mu, p.eps, p.beta_min, p.beta_max, p.block_len, p.lam, g,
                       0.0 if p.adapt_gate_db is None else p.adapt_gate_db], dtype=float)
    if f.eq_b is None:
        eq_b = eq_a = _EMPTY
    else:
        eq_a = np.asarray(f.eq_a, dtype=float)
        eq_b = np.zeros(eq_a.shape[0])
        eq_b[:len(f.eq_b)] = f.eq_b
    h = np.array(f.h_delayed, dtype=float)  # a writable copy: numba compiles read-only arrays separately
    return h, int(f.latency), eq_b, eq_a, pp, mode, gate, n_window


def _replace(state: _DiffState, **changes) -> _DiffState:
    values = dict(vars(state))
    values.update(changes)
    return _DiffState(**values)


class ElkoBeamformer(_DifferentialBase):
    """Elko's adaptive first-order differential microphone (back-to-back cardioids + NLMS beta).

    Parameters (``ElkoBeamformer.Params``)
    --------------------------------------
    spacing_m, c_mps : pair spacing (m) and speed of sound (m/s); ``T = spacing_m / c_mps``.
    mu : NLMS step, ``0 < mu < 2`` (default 0.05).
    update : ``"block"`` (default, vectorized) or ``"sample"`` (per-sample NLMS, a Python loop).
    block_len : adaptation block length in samples (default 16 = 1 ms at 16 kHz).
    lam : power smoothing of the sample variant, ``0 <= lam < 1`` (default 0.99).
    eps : regularisation relative to the front-mic power (default 1e-6).
    beta0 : initial beta in ``[0, 1]`` (default 0: forward cardioid).
    adapt_gate_db : None (default: always adapt) or the gate threshold in dB, ``[-60, 60]``:
        freeze beta where ``10 log10(P_F / P_B)`` exceeds ``min(floor, 0)`` by more than this.
    gate_lam : one-pole smoothing of the gate powers, ``[0, 1)``; None (default) uses ``lam``.
    gate_floor_s : window (s) of the running minimum ``floor`` of the gate ratio, ``[0, 60]``;
        0 (default) compares with 0 dB.  Cost per call is O(window) (the sample variant keeps
        one ratio per sample of the window).
    beta_min, beta_max : limits beta is clipped to at every update (default 0 and 1: the null
        in the rear half plane; ``0 <= beta_min <= beta_max <= 1``).
    eq, eq_fc_hz, eq_hf : look-direction equaliser (see :mod:`enhancers.beam.differential`).
    fd_half_len : half length of the fractional-delay filter = latency (samples).
    t_samples : internal delay T in samples, overriding ``spacing_m / c_mps`` (None: from the
        geometry; the thesis uses exactly one sample, "internally delayed by one sample each").
    """

    name: ClassVar[str] = "eb"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "Elko adaptive first-order differential beamformer (NLMS beta, clipped to [0, 1])"

    @dataclass(frozen=True)
    class Params(_DifferentialParams):
        mu: float = 0.05
        update: str = "block"
        block_len: int = 16
        lam: float = 0.99
        eps: float = 1e-6
        beta0: float = 0.0
        adapt_gate_db: float | None = None
        gate_lam: float | None = None
        gate_floor_s: float = 0.0
        beta_min: float = 0.0
        beta_max: float = 1.0

        def __post_init__(self):
            self._check_common()
            check_range("beta_min", self.beta_min, 0.0, 1.0)
            check_range("beta_max", self.beta_max, self.beta_min, 1.0)
            check_range("mu", self.mu, 0.0, 2.0, lo_open=True, hi_open=True)
            check_choice("update", self.update, ("block", "sample"))
            check_int("block_len", self.block_len, minimum=1)
            check_range("lam", self.lam, 0.0, 1.0, hi_open=True)
            check_positive("eps", self.eps, allow_zero=True)
            check_range("beta0", self.beta0, self.beta_min, self.beta_max)
            if self.adapt_gate_db is not None:
                check_range("adapt_gate_db", self.adapt_gate_db, -60.0, 60.0)
            if self.gate_lam is not None:
                check_range("gate_lam", self.gate_lam, 0.0, 1.0, hi_open=True)
            check_range("gate_floor_s", self.gate_floor_s, 0.0, 60.0)

    def _initial_beta(self) -> float:
        return float(self.params.beta0)

    def _gate(self, cF, cB, state, at, n_window):
        """Adaptation gate: True where the update is frozen (a frontal source dominates).

        ``r = 10 log10(P_F / P_B)`` of the one-pole smoothed cardioid powers
        (``P[n] = g P[n-1] + (1 - g) c[n]^2``, ``g = gate_lam`` or ``lam``) at the samples ``at``;
        frozen where ``r > min(floor, 0) + adapt_gate_db``, ``floor`` = minimum of ``r`` over the
        last ``n_window`` decisions (0: no floor, reference 0 dB).

        Returns ``(frozen, state changes)``, or ``(None, {})`` when the gate is off.
        """
        p = self.params
        if p.adapt_gate_db is None:
            return None, {}
        g = float(p.lam if p.gate_lam is None else p.gate_lam)
        pf, _ = lfilter([1 - g], [1, -g], cF * cF, zi=[g * state.g_f])
        pb, _ = lfilter([1 - g], [1, -g], cB * cB, zi=[g * state.g_b])
        # silence gives r = 0 dB (never NaN)
        r = 10.0 * np.log10((pf[at] + _TINY) / (pb[at] + _TINY))
        changes = {"g_f": float(pf[-1]), "g_b": float(pb[-1])}
        ref = np.zeros_like(r)
        if n_window > 1:
            hist = np.full(n_window - 1, np.inf) if state.g_hist is None else state.g_hist
            full = np.concatenate([hist, r])
            # causal running minimum over the last n_window values (origin shifts scipy's centred window)
            floor = minimum_filter1d(full, n_window, origin=(n_window - 1) // 2, mode="constant", cval=np.inf)
            ref = np.minimum(floor[n_window - 1:], 0.0)
            changes["g_hist"] = full[full.shape[0] - (n_window - 1):].copy()
        elif n_window == 1:
            ref = np.minimum(r, 0.0)
        return r > ref + float(p.adapt_gate_db), changes

    def _betas(self, cF, cB, p1, state):
        if self.params.update == "block":
            return self._betas_block(cF, cB, p1, state)
        return self._betas_sample(cF, cB, p1, state)

    def _betas_block(self, cF, cB, p1, state):
        p = self.params
        B, mu, eps = int(p.block_len), float(p.mu), float(p.eps)
        n = cF.shape[0]
        g = state.phase + np.arange(n)
        k = g // B                      # adaptation block of each sample, 0 = the open one
        n_blk = int(k[-1]) + 1
        s_fb = np.bincount(k, cF * cB, minlength=n_blk)
        s_bb = np.bincount(k, cB * cB, minlength=n_blk)
        s_11 = np.bincount(k, p1 * p1, minlength=n_blk)
        s_fb[0] += state.s_fb
        s_bb[0] += state.s_bb
        s_11[0] += state.s_11
        n_closed = (state.phase + n) // B
        beta = state.beta
        # scalar recursion over blocks (clipping makes it nonlinear); Python floats are fastest here.
        # beta += mu sum(y cB) / den with sum(y cB) = sum(cF cB) - beta sum(cB^2)  (y with the old beta)
        gain = mu * s_fb[:n_closed] / (s_bb[:n_closed] + eps * s_11[:n_closed] + _TINY)
        keep = 1.0 - mu * s_bb[:n_closed] / (s_bb[:n_closed] + eps * s_11[:n_closed] + _TINY)
        # gate decision at the last sample of each closed block; a frozen block leaves beta unchanged
        ends = B - 1 - state.phase + B * np.arange(n_closed)
        n_win = int(math.ceil(float(p.gate_floor_s) * state.fs / B)) if p.gate_floor_s > 0 else 0
        frozen, gate_state = self._gate(cF, cB, state, ends, n_win)
        if frozen is not None:
            gain[frozen] = 0.0
            keep[frozen] = 1.0
        gain, keep = gain.tolist(), keep.tolist()
        lo, hi = float(p.beta_min), float(p.beta_max)
        betas_l = [beta]
        for g_i, k_i in zip(gain, keep):
            beta = beta * k_i + g_i
            beta = lo if beta < lo else (hi if beta > hi else beta)
            betas_l.append(beta)
        betas = np.asarray(betas_l[:n_blk])[k]
        open_sums = (0.0, 0.0, 0.0) if n_closed == n_blk else (
            float(s_fb[-1]), float(s_bb[-1]), float(s_11[-1]))
        new = _replace(state, beta=beta, phase=(state.phase + n) % B, s_fb=open_sums[0],
                       s_bb=open_sums[1], s_11=open_sums[2], **gate_state)
        return betas, new

    def _betas_sample(self, cF, cB, p1, state):
        p = self.params
        mu, eps, lam = float(p.mu), float(p.eps), float(p.lam)
        pb, _ = lfilter([1 - lam], [1, -lam], cB * cB, zi=[lam * state.p_b])
        p11, _ = lfilter([1 - lam], [1, -lam], p1 * p1, zi=[lam * state.p_1])
        den = pb + eps * p11 + _TINY
        n_win = int(math.ceil(float(p.gate_floor_s) * state.fs)) if p.gate_floor_s > 0 else 0
        frozen, gate_state = self._gate(cF, cB, state, slice(None), n_win)
        # a frozen sample has step 0: beta += 0 * (...) leaves it exactly unchanged
        step = np.full(cF.shape[0], mu) if frozen is None else np.where(frozen, 0.0, mu)
        beta = state.beta
        lo, hi = float(p.beta_min), float(p.beta_max)
        betas = np.empty(cF.shape[0])
        for i, (f_, b_, d_, m_) in enumerate(zip(cF.tolist(), cB.tolist(), den.tolist(), step.tolist())):
            betas[i] = beta
            beta += m_ * (f_ - beta * b_) * b_ / d_
            beta = lo if beta < lo else (hi if beta > hi else beta)
        return betas, _replace(state, beta=beta, p_b=float(pb[-1]), p_1=float(p11[-1]), **gate_state)


class GatedElkoBeamformer(ElkoBeamformer):
    """:class:`ElkoBeamformer` with the adaptation gate on by default (registry name ``"eb-gated"``).

    Defaults ``adapt_gate_db=3``, ``gate_floor_s=1``: freeze beta while the forward/backward
    cardioid power ratio is more than 3 dB above its 1-s minimum (capped at 0 dB), i.e. while
    a frontal source dominates.  A subclass (not a registry alias of ``"eb"``) so results
    rows, ``spec`` and the conformance checks carry its own name.
    """

    name: ClassVar[str] = "eb-gated"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "Elko adaptive beamformer, beta frozen while a frontal source dominates"

    @dataclass(frozen=True)
    class Params(ElkoBeamformer.Params):
        adapt_gate_db: float | None = 3.0
        gate_floor_s: float = 1.0


@dataclass(frozen=True)
class _FixedParams(_DifferentialParams):
    beta: float = 0.0

    def __post_init__(self):
        self._check_common()
        check_range("beta", self.beta, 0.0, 1.0)


class _FixedBase(_DifferentialBase):
    def _initial_beta(self) -> float:
        return float(self.params.beta)

    def _betas(self, cF, cB, p1, state):
        return np.full(cF.shape[0], float(self.params.beta)), state


class FixedCardioid(_FixedBase):
    """Fixed first-order differential pattern ``y = cF - beta cB`` with ``beta = 0`` (cardioid, DI 4.77 dB)."""

    name: ClassVar[str] = "cardioid"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "fixed differential cardioid (beta 0), look-direction equalised"

    @dataclass(frozen=True)
    class Params(_FixedParams):
        beta: float = 0.0


class FixedHypercardioid(_FixedBase):
    """Fixed first-order differential pattern with ``beta = 0.5`` (hypercardioid, DI 6.02 dB)."""

    name: ClassVar[str] = "hypercardioid"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "fixed differential hypercardioid (beta 0.5), look-direction equalised"

    @dataclass(frozen=True)
    class Params(_FixedParams):
        beta: float = 0.5
