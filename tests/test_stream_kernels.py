"""The compiled per-block steps (enhancers.kernels.stream) against the numpy steps they replace.

Oracle: the numpy step of the same enhancer, reached by setting ``stream_kernels.MAX_BLOCK = 0``
(every block then takes the numpy path, the one batch processing uses), on the same input cut
into the same random block sizes.  Tolerance: 1e-12 relative to the output's peak (the kernels
sum the FIR taps in another order; everything else is the same arithmetic in the same order).
"""

from __future__ import annotations

import numpy as np
import pytest
from signals import FS, harmonic_speechlike, lowpass_noise, plane_wave_pair

import enhancers.kernels.stream as sk
from enhancers.core.registry import make
from scenesim.errors import ParameterError

REL_TOL = 1e-12

CASES = [
    ("eb", {}, "differential_block"),
    ("eb", {"update": "sample", "mu": 0.02}, "differential_block"),
    ("eb", {"eq": False, "block_len": 7, "beta_max": 0.8}, "differential_block"),
    ("eb-gated", {}, "differential_block"),
    ("eb-gated", {"gate_floor_s": 0.005, "gate_lam": 0.5, "block_len": 7}, "differential_block"),
    ("eb-gated", {"gate_floor_s": 0.0}, "differential_block"),
    ("cardioid", {}, "differential_block"),
    ("hypercardioid", {"eq_hf": 0.0, "t_samples": 1.0}, "differential_block"),
    ("das", {}, "fir_pair_block"),
    ("das", {"look_az_deg": 40.0, "fir_taps": 20}, "fir_pair_block"),
    ("ss", {}, "ss_block"),
    ("ss", {"snr_def": "instant", "omin": 1.5, "gain_max": 10.0}, "ss_block"),
    ("ss", {"n_sub": 3, "sub_len": 5, "frame_len": 128, "hop": 32}, "ss_block"),
    ("ss", {"frame_len": 240, "hop": 80}, "ss_ms1994_frames"),  # not 2^k: numpy filter bank + compiled frames
    ("ss", {"power_bins": 2, "gain_bins": 3, "gain_smooth": 0.6}, "ss_block"),  # cross-term averaging (issue 16)
    ("ss", {"power_bins": 128, "gain_bins": 1, "gain_smooth": 0.3, "snr_def": "instant"}, "ss_block"),  # widest
    ("ss", {"power_bins": 1, "gain_bins": 120, "gain_smooth": 0.7, "frame_len": 240, "hop": 80}, "ss_ms1994_frames"),
    ("ss", {"subtract": "power"}, "ss_block"),  # power subtraction (issue 30)
    ("ss", {"subtract": "power", "osub_slope": 0.0, "osub_min": 2.0, "osub0": 2.0, "subf": 0.05,
            "frame_len": 240, "hop": 80}, "ss_ms1994_frames"),
    ("ss-ms2001", {}, "ms2001_frames"),
    ("ss-ms2001", {"td": 0.3, "nu": 3, "snr_def": "instant"}, "ms2001_frames"),
    ("mmse-lsa", {}, "ms2001_frames"),
    ("superdirective", {}, "beam_block"),
    ("superdirective", {"look_az_deg": 40.0, "wng_min_db": -3.0, "frame_len": 128, "hop": 32}, "beam_block"),
]


def _two_mic_input(rng, n=6000):
    """Noise at 120 deg throughout and a talker at 45 deg in the second half (the gate freezes and adapts)."""
    x = plane_wave_pair(lowpass_noise(n, cutoff_hz=1000, rng=rng), az_deg=120)
    x[:, n // 2:] += 3 * plane_wave_pair(harmonic_speechlike(n), az_deg=45)[:, n // 2:]
    return x + 0.01 * rng.standard_normal(x.shape)


def _one_mic_input(rng, n=3 * FS):
    """White noise whose level steps by 20 dB, plus a speech-like signal: the minimum tracking moves."""
    x = 0.05 * rng.standard_normal(n)
    x[n // 3: 2 * n // 3] *= 10.0
    return (x + 0.3 * harmonic_speechlike(n))[None]


def _stream(e, x, edges):
    state, parts = e.init_state(FS), []
    for a, b in zip(edges[:-1], edges[1:]):
        out, state = e.process_block(x[:, a:b], state)
        parts.append(out)
    return np.concatenate(parts, axis=-1), state


@pytest.mark.parametrize(("name", "kwargs", "kernel"), CASES)
def test_compiled_step_equals_numpy_step(name, kwargs, kernel, rng, monkeypatch):
    """Random block sizes 1..400 (and a 160-sample stretch): compiled == numpy step to 1e-12 relative,
    and the kernel really ran (counted); the eb family also ends with the same beta."""
    e = make(name, **kwargs)
    x = _two_mic_input(rng) if e.tags.channels_in == 2 else _one_mic_input(rng)
    n = x.shape[-1]
    sizes = np.concatenate([rng.integers(1, 400, size=n // 100), np.full(n // 160, 160)])
    edges = np.unique(np.concatenate([[0], np.minimum(np.cumsum(sizes), n), [n]]))
    calls = []
    real = getattr(sk, kernel)
    monkeypatch.setattr(sk, kernel, lambda *a: calls.append(1) or real(*a))
    fast, fast_state = _stream(e, x, edges)
    assert len(calls) >= len(edges) // 2  # ss: a block without a complete frame skips the kernel
    monkeypatch.setattr(sk, "MAX_BLOCK", 0)
    ref, ref_state = _stream(e, x, edges)
    assert np.max(np.abs(ref)) > 0
    assert np.max(np.abs(fast - ref)) <= REL_TOL * np.max(np.abs(ref))
    if hasattr(ref_state, "beta"):
        assert abs(fast_state.beta - ref_state.beta) <= REL_TOL


@pytest.mark.parametrize(("name", "kwargs"), [("ss", {}), ("ss", {"power_bins": 2, "gain_bins": 2, "gain_smooth": 0.6}),
                                             ("superdirective", {})])
def test_fused_state_survives_switching_to_numpy_and_back(name, kwargs, rng, monkeypatch):
    """The fused kernels (``ss_block``, ``beam_block``) keep the filter bank's (and ss's tracker's) state
    in their own arrays; blocks longer than ``MAX_BLOCK`` (numpy path) in between must hand that state
    over both ways.  Oracle: the numpy step on every block (``MAX_BLOCK = 0``), 1e-12 of the output peak;
    both paths really ran (block sizes on both sides of ``MAX_BLOCK``); ss's smoothed gain hands over too."""
    e = make(name, **kwargs)
    x = _two_mic_input(rng, n=3 * FS) if e.tags.channels_in == 2 else _one_mic_input(rng)
    n = x.shape[-1]
    edges = np.unique(np.concatenate([[0], np.minimum(np.cumsum(rng.integers(1, 700, size=n // 200)), n), [n]]))
    monkeypatch.setattr(sk, "MAX_BLOCK", 350)
    assert np.any(np.diff(edges) > 350) and np.any(np.diff(edges) <= 350)
    mixed, _ = _stream(e, x, edges)
    monkeypatch.setattr(sk, "MAX_BLOCK", 0)
    ref, _ = _stream(e, x, edges)
    assert np.max(np.abs(mixed - ref)) <= REL_TOL * np.max(np.abs(ref))


def test_compiled_gate_freezes_and_adapts(rng):
    """The gated compiled step both holds beta (talker present) and moves it: the equality above is not
    an equality of two never-gated runs.  Oracle: beta per 10 ms block, from the compiled path's state."""
    e = make("eb-gated", gate_floor_s=0.005, gate_lam=0.5, block_len=7)
    x = _two_mic_input(rng)
    state, betas = e.init_state(FS), []
    for a in range(0, x.shape[-1], 7):
        _, state = e.process_block(x[:, a:a + 7], state)
        betas.append(state.beta)
    steps = np.diff(betas)
    assert np.any(steps == 0) and np.any(steps != 0)


def test_block_fast_validation_still_rejects_bad_blocks():
    """The per-block check (a finite sum of squares) keeps check_signal's errors: NaN/Inf name ``block``;
    a finite block whose sum of squares overflows and an int block are accepted (the latter converted
    to float64)."""
    e = make("eb")
    state = e.init_state(FS)
    for value in (np.nan, np.inf, -np.inf):
        bad = np.zeros((2, 160))
        bad[1, 80] = value
        with pytest.raises(ParameterError) as info:
            e.process_block(bad, state)
        assert info.value.name == "block"
    with pytest.raises(ParameterError):
        e.process_block(np.zeros((3, 160)), state)
    huge = np.full((2, 4), 1e200)
    out, state = e.process_block(huge, e.init_state(FS))
    assert out.shape == (1, 4)
    out, _ = e.process_block(np.ones((2, 5), dtype=np.int16), e.init_state(FS))
    assert out.dtype == np.float64 and out.shape == (1, 5)
