"""The compiled frame step (enhancers.kernels.frames, enhancers.kernels.robust) equals the numpy reference.

Oracle: the numpy step of enhancers.beam.mic_calibration / enhancers.beam.subband_eb (``fast_frames.COMPILED =
False``), itself checked against the loop references of tests/subband_reference.py.  Tolerance: 1e-12
of each array's largest magnitude (outputs, records and carried state), freeze masks identical.  The
kernel follows the reference's arithmetic except the slope fit's einsum sums and 3x3 solve (reordered),
so the measured differences are ~1e-15.  Input: 4 s (500 frames, the 1-s floors wrap four times) of
diffuse noise with a 1 dB / 5 deg rear-mic mismatch, a rear plane wave and a frontal burst, fed in
uneven blocks of frames (1, 2, 127, 1, the rest).
"""

from __future__ import annotations

import numpy as np
import pytest
from mismatch import apply_mismatch
from signals import FS, SPACING_M, plane_wave_pair

from enhancers.beam.mic_calibration import CalibrationState
from enhancers.beam.subband_eb import SubbandState
from enhancers.core.registry import make
from enhancers.kernels import frames as fast_frames
from enhancers.kernels import robust as kr
from scenesim.scene.noise_fields import diffuse_noise

TOL = 1e-12
BLOCKS = (0, 1, 3, 130, 131, None)

CASES = [
    ("mic-calibration", {}),
    ("mic-calibration", dict(min_coherence=0.0, estimate_every=3, smooth_bins=2)),
    ("mic-calibration", dict(floor_s=0.0, fit_band_hz=(300.0, 6000.0))),
    ("eb-subband", {}),
    ("eb-subband", dict(adapt_gate_db=3.0, gate_floor_s=0.5, gate_lam=0.8, das_mix=True, eq_phase=True,
                        mix_smooth_bins=4, eq_noise_gain_db=9.0, eq_highpass_hz=100.0, beta0=0.3)),
    ("eb-subband", dict(adapt_gate_db=2.0, eq=False)),
    ("eb-robust", {}),
    ("eb-robust", dict(calibrate=False)),
]


@pytest.fixture(scope="module")
def frames():
    """Spectra ``(2, 500, 129)`` of the test scene (analysed once with the default filter bank)."""
    rng = np.random.default_rng(20)
    n = 4 * FS
    x = apply_mismatch(diffuse_noise(n, SPACING_M, fs=FS, rng=rng), fs=FS, gain_db=1.0, phase_deg=5.0,
                       highpass_hz=(80.0, 120.0))
    x += 0.5 * plane_wave_pair(rng.standard_normal(n), az_deg=150)
    x[:, FS:2 * FS] += 3.0 * plane_wave_pair(rng.standard_normal(FS), az_deg=10)
    return make("mic-calibration").filterbank.analyze(x)


def _run(e, X, compiled: bool):
    """``e``'s frame step over ``X`` in the uneven blocks: ``(Y, record, final state)``."""
    old = fast_frames.COMPILED
    fast_frames.COMPILED = compiled
    try:
        algo = e._algo_init(FS, X.shape[2])
    finally:
        fast_frames.COMPILED = old
    assert isinstance(algo, fast_frames.FastState) == compiled
    ys, recs = [], []
    for lo, hi in zip(BLOCKS[:-1], BLOCKS[1:]):
        Y, algo, rec = e._frames(X[:, lo:hi], algo, FS)
        ys.append(Y)
        recs.append(rec)
    record = {k: np.concatenate([r[k] for r in recs if k in r], axis=0) for k in recs[-1]}
    return np.concatenate(ys, axis=1), record, algo


def _close(name, actual, desired):
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape, name
    if desired.dtype == bool:
        np.testing.assert_array_equal(actual, desired, err_msg=name)
        return
    scale = np.max(np.abs(desired[np.isfinite(desired)]), initial=0.0)
    err = np.max(np.abs(actual - desired), initial=0.0)
    assert err <= TOL * scale, f"{name}: {err:.3g} > {TOL} x {scale:.3g}"


def _deque_floor(fast, g: int, n_window: int):
    """The minimum of the last ``n_window - 1`` floor ratios per bin (the reference's ``hist.min(0)``)."""
    _, ipar, _, _, _, _, val, idx, hs = fast.args
    t_next = ipar[kr.I_NFRAMES]
    out = np.full(val.shape[1], np.inf)
    for k in range(val.shape[1]):
        for j in range(hs[g, 1, k]):
            slot = (hs[g, 0, k] + j) % n_window
            if idx[g, k, slot] >= t_next - (n_window - 1):
                out[k] = val[g, k, slot]
                break
    return out


def _compare_state(fast, ref):
    """Every carried quantity of the compiled state against the reference state."""
    par, ipar, _, _, rs, cs, *_ = fast.args
    cal = ref if isinstance(ref, CalibrationState) else (ref[0] if isinstance(ref, tuple) else None)
    cal = cal if fast.calibrate else None  # eb-robust with calibrate=False: the reference's stays unused
    sub = ref if isinstance(ref, SubbandState) else (ref[1] if isinstance(ref, tuple) else None)
    if cal is not None:
        assert ipar[kr.I_NFRAMES] == cal.n_frames
        for name, row in (("S11", 0), ("S22", 1), ("S21", 2)):
            _close(name, cs[kr.C_AVG + row], cal.avg[row])
        _close("r_last", cs[kr.C_RLAST], cal.r_last)
        _close("raw_last", cs[kr.C_RAWLAST], cal.raw_last)
        _close("counts", rs[kr.R_COUNTS], cal.counts)
        for g, (row, gate) in enumerate(((kr.R_QB, cal.q_bin), (kr.R_QW, cal.q_band))):
            _close("gate pf", rs[row], gate.pf)
            _close("gate pb", rs[row + 1], gate.pb)
            if ipar[kr.I_NWC] > 1:
                _close("floor", _deque_floor(fast, g, ipar[kr.I_NWC]), gate.hist.min(axis=0))
    if sub is not None:
        for name, row, value in (("beta", kr.R_BETA, sub.beta), ("p_b", kr.R_PB, sub.p_b), ("p_1", kr.R_P1, sub.p_1),
                                 ("S_YD", kr.R_SYD, sub.alpha), ("S_DD", kr.R_SDD, sub.p_d),
                                 ("S_11", kr.R_SM, sub.p_m)):
            _close(name, rs[row], value)
        if ipar[kr.I_GATE]:
            _close("beta gate pf", rs[kr.R_GATE], sub.gate.pf)
            _close("beta gate pb", rs[kr.R_GATE + 1], sub.gate.pb)
            if ipar[kr.I_NWG] > 1:
                _close("beta gate floor", _deque_floor(fast, 2, ipar[kr.I_NWG]), sub.gate.hist.min(axis=0))


@pytest.mark.parametrize("name, kwargs", CASES)
def test_compiled_step_equals_the_numpy_reference(frames, name, kwargs):
    e = make(name, **kwargs)
    y_ref, rec_ref, st_ref = _run(e, frames, compiled=False)
    y, rec, st = _run(e, frames, compiled=True)
    _close("output", y, y_ref)
    assert rec.keys() == rec_ref.keys()
    for key in rec_ref:
        _close(key, rec[key], rec_ref[key])
    if "frozen" in rec_ref:
        assert 0.05 < rec_ref["frozen"].mean() < 0.95  # the freeze rules are exercised both ways
    _compare_state(st, st_ref)


@pytest.mark.parametrize("name, kwargs", [("mic-calibration", {}), ("eb-subband", {}), ("eb-robust", {}),
                                          ("eb-robust", dict(frame_len=192, hop=96))])
def test_compiled_batch_equals_reference_batch_and_streaming(name, kwargs):
    """Whole enhancer: batch (compiled) == batch (reference) to 1e-12 of the peak, and streaming in 10 ms
    blocks (the fused kernel: its own FFT and overlap-add; a frame length that is not a power of two
    streams through the numpy filter bank and the compiled frames) == batch to 1e-12 of the peak."""
    rng = np.random.default_rng(5)
    x = 0.1 * rng.standard_normal((2, FS))
    e = make(name, **kwargs)
    y = e.process(x, FS).output
    old = fast_frames.COMPILED
    fast_frames.COMPILED = False
    try:
        y_ref = e.process(x, FS).output
    finally:
        fast_frames.COMPILED = old
    _close("batch", y, y_ref)
    state, outs = e.init_state(FS), []
    for i in range(0, x.shape[1], 160):
        out, state = e.process_block(x[:, i:i + 160], state)
        outs.append(out)
    assert isinstance(state.algo, fast_frames.FastState)
    assert (state.algo.wola is None) == ("frame_len" in kwargs)  # the fused path ran where it can
    _close("streaming", np.concatenate(outs, axis=1), y)


def test_fft_pair_equals_numpy():
    """The fused step's FFTs: analysis of two windowed frames == numpy's rfft, synthesis of one or two
    channels == irfft times the window (imaginary DC / Nyquist parts ignored, as numpy does), to 1e-12
    of the spectrum's / frame's peak (both are 256-point FFTs: they differ by rounding, ~1e-16)."""
    from enhancers.kernels.wola import analyze_pair, fft_tables, synthesize

    rng = np.random.default_rng(9)
    n = 256
    rev, tw = fft_tables(n)
    w = np.hamming(n)
    x = rng.standard_normal((2, n))
    X = np.empty((2, n // 2 + 1), dtype=complex)
    analyze_pair(x[0], x[1], w, rev, tw, X[0], X[1])
    _close("rfft", X, np.fft.rfft(x * w, axis=-1))
    Y = rng.standard_normal((2, n // 2 + 1)) + 1j * rng.standard_normal((2, n // 2 + 1))
    y = np.empty((2, n))
    synthesize(Y[0], Y[1], True, w, rev, tw, y[0], y[1])
    _close("irfft pair", y, np.fft.irfft(Y, n=n, axis=-1) * w)
    synthesize(Y[1], Y[1], False, w, rev, tw, y[0], y[1])
    _close("irfft one", y[0], np.fft.irfft(Y[1], n=n) * w)


def test_talker_blind_mode_runs_the_reference():
    """The kernel does not cover the frame rule / ramp: those parameter sets keep the numpy step."""
    assert not isinstance(make("mic-calibration", frame_q_db=5.0)._algo_init(FS, 129), fast_frames.FastState)
    assert isinstance(make("eb-robust", ramp_frames=40.0)._algo_init(FS, 129), tuple)
    assert isinstance(make("eb-robust")._algo_init(FS, 129), fast_frames.FastState)


def test_a_field_the_kernel_does_not_know_runs_the_reference():
    """An opt-in variant added to the params later (here a made-up field) keeps the reference once set."""
    import dataclasses

    from enhancers.beam.mic_calibration import MicCalibration

    @dataclasses.dataclass(frozen=True)
    class Later(MicCalibration.Params):
        new_variant: float = 0.0

    assert fast_frames.kernel_supports(Later())
    assert not fast_frames.kernel_supports(Later(new_variant=1.0))


def test_sums_follow_numpy_and_scipy_bitwise():
    """The kernel's band sum and bin smoothing reproduce np.sum (pairwise) and uniform_filter1d exactly."""
    from scipy.ndimage import uniform_filter1d

    rng = np.random.default_rng(0)
    for n in (3, 8, 57, 65, 112, 128):  # up to numpy's block (128 real or 64 complex values; longer: rounding)
        x = np.exp(rng.normal(0.0, 3.0, n + 5))  # 8 orders of magnitude: any reordering shows
        assert kr._pairwise_sum(x, 2, n + 2, 8) == x[2:n + 2].sum()
        if n <= 65:
            z = x[:n] * np.exp(1j * rng.uniform(-3, 3, n))
            s = z[1:].sum()
            assert (kr._pairwise_sum(z.real, 1, n, 4), kr._pairwise_sum(z.imag, 1, n, 4)) == (s.real, s.imag)
    x = np.exp(rng.normal(0.0, 3.0, 129))
    out = np.empty(129)
    kr._box(x, 8, out)
    np.testing.assert_array_equal(out, uniform_filter1d(x, 17, mode="nearest"))
