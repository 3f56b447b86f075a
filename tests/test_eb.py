"""Elko's adaptive differential beamformer and the fixed patterns, against exact oracles.

Plane waves come from ``signals.plane_wave_pair`` (exact FFT-domain delays), independent of the
project's fractional-delay filters.  Default pair: d = 0.0214 m, c = 343 m/s, fs = 16 kHz (T fs = 0.998).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from signals import (
    C_MPS,
    FS,
    SPACING_M,
    cardioid_pair,
    harmonic_speechlike,
    lowpass_noise,
    plane_wave_pair,
)

from enhancers.beam.differential import branch_signals
from enhancers.beam.eb import ElkoBeamformer, FixedCardioid, FixedHypercardioid, GatedElkoBeamformer
from enhancers.core.registry import make
from scenesim.errors import ParameterError

N = 4 * FS
HALF = N // 2


def _null_depth_db(result, look, n_from=HALF):
    """Output power of a look-direction (0 deg) replay over the interferer's output power, converged part."""
    y_look = result.replay(look)
    return 10 * np.log10(np.mean(y_look[:, n_from:] ** 2) / np.mean(result.output[:, n_from:] ** 2))


@pytest.mark.parametrize("update", ["block", "sample"])
@pytest.mark.parametrize("theta", [100, 120, 150, 180])
def test_beta_converges_to_closed_form_null_angle(theta, update, rng):
    """Oracle: beta = (1 + cos th)/(1 - cos th) for noise below 1 kHz (low-frequency closed form,
    0.704/0.333/0.072/0), mean over the second half within 0.02; null depth >= 25 dB."""
    s = lowpass_noise(N, cutoff_hz=1000, rng=rng)
    r = ElkoBeamformer(update=update).process(plane_wave_pair(s, az_deg=theta), FS)
    c = np.cos(np.radians(theta))
    assert abs(r.trace["beta"][HALF:].mean() - (1 + c) / (1 - c)) <= 0.02
    look = plane_wave_pair(lowpass_noise(N, cutoff_hz=1000, rng=rng), az_deg=0)
    assert _null_depth_db(r, look) >= 25.0


def test_broadside_white_noise_nulled_by_dipole(rng):
    """White broadband noise at 270 deg: beta -> 1 (dipole, clipped) and >= 25 dB null at all frequencies."""
    r = ElkoBeamformer().process(plane_wave_pair(rng.standard_normal(N), az_deg=270), FS)
    assert r.trace["beta"][HALF:].mean() >= 0.98
    assert _null_depth_db(r, plane_wave_pair(rng.standard_normal(N), az_deg=0)) >= 25.0


@pytest.mark.parametrize("theta", [135, 160])
def test_beta_converges_to_least_squares_solution(theta, rng):
    """Oracle: beta* = clip(sum(cF cB)/sum(cB^2), 0, 1) with cF, cB from exact FFT delays (white noise:
    a frequency-dependent null, algorithms.md quotes ~0.31 at 135 deg); within 0.02."""
    x = plane_wave_pair(rng.standard_normal(N), az_deg=theta)
    cF, cB = cardioid_pair(x, delay_samples=SPACING_M / C_MPS * FS)
    beta_ls = np.clip(np.sum(cF * cB) / np.sum(cB * cB), 0, 1)
    r = ElkoBeamformer().process(x, FS)
    assert abs(r.trace["beta"][HALF:].mean() - beta_ls) <= 0.02


def test_whole_sample_delay_uses_exact_shifts(rng):
    """c = 0.0214 * 16000 m/s makes T exactly one sample: the delayed branch is a pure shift, and the
    forward cardioid nulls a 180 deg plane wave to rounding (oracle: cF = p1[n] - p2[n-1] = 0)."""
    e = FixedCardioid(c_mps=SPACING_M * FS, eq=False)
    assert np.count_nonzero(e.filters(FS).h_delayed) == 1
    x = plane_wave_pair(rng.standard_normal(8000), az_deg=180, c_mps=SPACING_M * FS)
    np.testing.assert_allclose(e.process(x, FS).output[:, 100:], 0.0, atol=1e-12)
    r = ElkoBeamformer(c_mps=SPACING_M * FS).process(
        plane_wave_pair(lowpass_noise(N, cutoff_hz=1000, rng=rng), az_deg=120, c_mps=SPACING_M * FS), FS)
    assert abs(r.trace["beta"][HALF:].mean() - 1 / 3) <= 0.02


@pytest.mark.parametrize("cls,di_db", [(FixedCardioid, 10 * np.log10(3)), (FixedHypercardioid, 10 * np.log10(4))])
def test_directivity_index_of_fixed_patterns(cls, di_db, rng):
    """Oracle: DI of a + (1-a) cos th = 4.77 dB (cardioid) / 6.02 dB (hypercardioid), within 0.1 dB.

    Measured from the implemented filter: output power of plane waves of 200-500 Hz noise from 8
    Gauss-Legendre nodes in cos(angle to the axis) (exact for the quadratic |H|^2 of a first-order
    pattern), DI = 10 log10(P(0) / (1/2 int P du)).
    """
    e = cls()
    s = lowpass_noise(FS, cutoff_hz=500, lo_hz=200, rng=rng)
    u, w = np.polynomial.legendre.leggauss(8)

    def power(az):
        return np.mean(e.process(plane_wave_pair(s, az_deg=az), FS).output[:, 2000:] ** 2)

    p_sphere = 0.5 * np.dot(w, [power(np.degrees(np.arccos(ui))) for ui in u])
    assert abs(10 * np.log10(power(0.0) / p_sphere) - di_db) <= 0.1


@pytest.mark.parametrize("cls", [FixedCardioid, ElkoBeamformer])
def test_equalised_look_response_is_flat(cls):
    """Impulse plane wave at 0 deg: equalised response within +-1 dB of 0 dB from 200 Hz to 6 kHz and
    0 dB at 1 kHz within 0.1 dB (unit look gain at 1 kHz by design)."""
    n = 16384
    imp = np.zeros(n)
    imp[1000] = 1.0
    y = cls().process(plane_wave_pair(imp, az_deg=0), FS).output[0]
    f = np.fft.rfftfreq(n, 1 / FS)
    h_db = 20 * np.log10(np.abs(np.fft.rfft(y)))
    band = (f >= 200) & (f <= 6000)
    assert np.all(np.abs(h_db[band]) <= 1.0), (h_db[band].min(), h_db[band].max())
    assert abs(h_db[np.argmin(np.abs(f - 1000))]) <= 0.1


def test_plain_integrator_rolls_off_as_documented():
    """eq_hf=0 is algorithms.md's first-order integrator: ~8 dB down at 6 kHz for T fs = 1
    (2 cos(w/2) roll-off; oracle 20 log10(cos(3 pi/8)/cos(pi/16)) = -8.2 dB), within 0.5 dB."""
    n = 16384
    imp = np.zeros(n)
    imp[1000] = 1.0
    y = FixedCardioid(eq_hf=0.0).process(plane_wave_pair(imp, az_deg=0), FS).output[0]
    h = np.abs(np.fft.rfft(y))
    k1, k6 = 1000 * n // FS, 6000 * n // FS
    expected = 20 * np.log10(np.cos(3 * np.pi / 8) / np.cos(np.pi / 16))
    assert abs(20 * np.log10(h[k6] / h[k1]) - expected) <= 0.5


@pytest.mark.parametrize("factory", [lambda: ElkoBeamformer(), lambda: ElkoBeamformer(update="sample"),
                                     lambda: FixedHypercardioid()])
def test_streaming_equals_batch_and_replay_is_exact(factory, rng):
    """Blocks of 1, 16, 97, 128 samples == batch (1e-9); replay(mixture) == output; replay is linear."""
    e = factory()
    x = rng.standard_normal((2, 2000))
    r = e.process(x, FS)
    for block in (1, 16, 97, 128):
        state, parts = e.init_state(FS), []
        for i in range(0, x.shape[-1], block):
            out, state = e.process_block(x[:, i:i + block], state)
            parts.append(out)
        np.testing.assert_allclose(np.concatenate(parts, axis=-1), r.output, rtol=0, atol=1e-9)
    pickle.loads(pickle.dumps(state))
    a = rng.standard_normal((2, 2000))
    np.testing.assert_allclose(r.replay(x), r.output, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.replay(a) + r.replay(x - a), r.output, rtol=0, atol=1e-9)
    assert r.trace["beta"].shape == (2000,)


def test_silence_gives_zero_and_beta_stays():
    r = ElkoBeamformer(beta0=0.3).process(np.zeros((2, 1000)), FS)
    assert np.all(r.output == 0) and np.all(r.trace["beta"] == 0.3)


@pytest.mark.parametrize("kwargs,name", [
    ({"mu": 2.0}, "mu"), ({"mu": 0.0}, "mu"), ({"update": "frame"}, "update"), ({"block_len": 0}, "block_len"),
    ({"lam": 1.0}, "lam"), ({"beta0": 1.5}, "beta0"), ({"spacing_m": -1.0}, "spacing_m"),
    ({"eq_fc_hz": 0.0}, "eq_fc_hz"), ({"eq_hf": 1.0}, "eq_hf"), ({"eq": "yes"}, "eq"),
    ({"adapt_gate_db": float("nan")}, "adapt_gate_db"), ({"adapt_gate_db": 61.0}, "adapt_gate_db"),
    ({"adapt_gate_db": "3"}, "adapt_gate_db"), ({"gate_lam": 1.0}, "gate_lam"), ({"gate_lam": -0.1}, "gate_lam"),
    ({"gate_floor_s": -1.0}, "gate_floor_s"), ({"gate_floor_s": None}, "gate_floor_s"),
])
def test_bad_params_name_the_field(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        ElkoBeamformer(**kwargs)


def test_params_json_round_trip():
    p = ElkoBeamformer.Params(mu=0.1, update="sample", eq_hf=0.5)
    assert ElkoBeamformer.Params.from_json(p.to_json()) == p
    assert FixedHypercardioid.Params().beta == 0.5 and FixedCardioid.Params().beta == 0.0


# -- adaptation gate (opt-in): freeze beta while a frontal source dominates ---------------------------
SCENE_N = 4 * FS
TALKER_AZ = 45.0


def _talker_noise(noise_az, *, noise="white", snr_db=0.0, seed=7):
    """(speech pair, noise pair): speech-like talker (harmonic bursts, 40 % pauses) at 45 deg and a
    plane-wave noise at ``noise_az``, scaled to ``snr_db`` at the front mic; exact FFT-domain delays."""
    rng = np.random.default_rng(seed)
    v = rng.standard_normal(SCENE_N) if noise == "white" else lowpass_noise(SCENE_N, cutoff_hz=1000, rng=rng)
    s_pair = plane_wave_pair(harmonic_speechlike(SCENE_N), az_deg=TALKER_AZ)
    v_pair = plane_wave_pair(v, az_deg=noise_az)
    v_pair *= np.sqrt(np.sum(s_pair[0] ** 2) / np.sum(v_pair[0] ** 2)) * 10 ** (-snr_db / 20)
    return s_pair, v_pair


def _snr_improvement_db(e, s_pair, v_pair, n_from=SCENE_N // 2):
    """SNR-I over the converged second half: replayed speech-only / noise-only output power ratio
    minus the input ratio at the front mic.  Returns (SNR-I in dB, median beta over the second half)."""
    r = e.process(s_pair + v_pair, FS)
    ys, yn = r.replay(s_pair)[0, n_from:], r.replay(v_pair)[0, n_from:]
    snr_out = 10 * np.log10(np.sum(ys ** 2) / np.sum(yn ** 2))
    snr_in = 10 * np.log10(np.sum(s_pair[0, n_from:] ** 2) / np.sum(v_pair[0, n_from:] ** 2))
    return snr_out - snr_in, float(np.median(r.trace["beta"][n_from:]))


def test_gate_is_off_by_default_and_registered_as_eb_gated():
    """Default behaviour unchanged: 'eb' has no gate; 'eb-gated' is the subclass with the gate on."""
    assert ElkoBeamformer.Params().adapt_gate_db is None and ElkoBeamformer.Params().gate_floor_s == 0.0
    g = make("eb-gated")
    assert type(g) is GatedElkoBeamformer and g.spec["name"] == "eb-gated"
    assert g.params.adapt_gate_db == 3.0 and g.params.gate_floor_s == 1.0
    assert make("eb-gated", adapt_gate_db=None).params.adapt_gate_db is None


@pytest.mark.parametrize("update", ["block", "sample"])
def test_gate_freezes_beta_for_a_frontal_talker_alone(update):
    """Talker alone at 45 deg: its cardioid power ratio is ~+15 dB (> 3 dB), so after the start-up the gated
    beta stays exactly constant, while the ungated NLMS is pulled to >= 0.9 (target leakage).  Two syllables
    (0.5 s, no pause: the envelope is smooth across the circular wrap, so the FFT delays leave no ringing in
    silence).  Start-up: the first 48 samples (the 33-tap branch filters filling with the zero history, which
    the circular test signal does not match, plus one block) may move beta (measured: the sample variant does)."""
    n = FS // 2
    x = plane_wave_pair(harmonic_speechlike(n), az_deg=TALKER_AZ)
    for floor_s in (0.0, 0.05):
        b = ElkoBeamformer(update=update, beta0=0.3, adapt_gate_db=3.0, gate_floor_s=floor_s).process(x, FS)
        assert np.ptp(b.trace["beta"][48:]) == 0.0
        if update == "block":
            assert np.all(b.trace["beta"] == 0.3)
    assert ElkoBeamformer(update=update, beta0=0.3).process(x, FS).trace["beta"][n // 2:].mean() >= 0.9


def test_gate_restores_the_rear_null_against_target_leakage():
    """Talker at 45 deg + white noise at 180 deg, 0 dB: the gated EB's converged beta is within 0.05 of the
    closed form 0 (algorithms.md section 5) and its SNR-I (by replay) beats the ungated EB by >= 10 dB.
    Measured: ungated 31.1 dB (median beta 0.002), gated 51.7 dB (0.000)."""
    s_pair, v_pair = _talker_noise(180)
    snri_ungated, _ = _snr_improvement_db(ElkoBeamformer(), s_pair, v_pair)
    snri_gated, beta_gated = _snr_improvement_db(GatedElkoBeamformer(), s_pair, v_pair)
    assert abs(beta_gated - 0.0) <= 0.05
    assert snri_gated >= snri_ungated + 10.0, (snri_gated, snri_ungated)


def test_gated_beta_reaches_closed_form_at_120_deg():
    """Noise low-passed below 1 kHz at 120 deg (+ talker at 45 deg, 0 dB): gated median beta within 0.05 of
    the low-frequency closed form (1 + cos th)/(1 - cos th) = 1/3.  Measured 0.336 (ungated 0.374)."""
    s_pair, v_pair = _talker_noise(120, noise="lowpass")
    _, beta_gated = _snr_improvement_db(GatedElkoBeamformer(), s_pair, v_pair)
    assert abs(beta_gated - 1 / 3) <= 0.05


def test_gate_does_not_hurt_the_thesis_270_deg_case():
    """White noise at 270 deg (talker and noise both pull beta to 1), 0 dB: gated SNR-I >= ungated - 1 dB.
    Measured 51.5 vs 51.5 dB."""
    s_pair, v_pair = _talker_noise(270)
    snri_ungated, _ = _snr_improvement_db(ElkoBeamformer(), s_pair, v_pair)
    snri_gated, _ = _snr_improvement_db(GatedElkoBeamformer(), s_pair, v_pair)
    assert snri_gated >= snri_ungated - 1.0, (snri_gated, snri_ungated)


def _reference_betas(e, x):
    """Slow per-sample/per-block reference of the gated NLMS (plain Python, written from the docstring):
    smoothed P_F, P_B, r = 10 log10(P_F/P_B), floor = min of r over the window, frozen if
    r > min(floor, 0) + threshold.  Uses the enhancer's own branch filters (tested separately)."""
    p = e.params
    f = e.filters(FS)
    n = x.shape[-1]
    cF, cB, p1 = branch_signals(np.concatenate([np.zeros((2, f.history)), x], axis=-1), f, n)
    g = p.lam if p.gate_lam is None else p.gate_lam
    B = p.block_len if p.update == "block" else 1
    win = int(np.ceil(p.gate_floor_s * FS / B)) if p.gate_floor_s > 0 else 0
    tiny = 1e-300
    pf = pb = pbn = p11 = 0.0
    beta, out, rs, acc = p.beta0, [], [], [0.0, 0.0, 0.0]
    for i in range(n):
        pf = g * pf + (1 - g) * cF[i] ** 2
        pb = g * pb + (1 - g) * cB[i] ** 2
        pbn = p.lam * pbn + (1 - p.lam) * cB[i] ** 2
        p11 = p.lam * p11 + (1 - p.lam) * p1[i] ** 2
        out.append(beta)
        if p.update == "block":
            acc = [acc[0] + cF[i] * cB[i], acc[1] + cB[i] ** 2, acc[2] + p1[i] ** 2]
            if (i + 1) % B:
                continue
            num, den = acc[0] - beta * acc[1], acc[1] + p.eps * acc[2] + tiny
            acc = [0.0, 0.0, 0.0]
        else:
            num, den = (cF[i] - beta * cB[i]) * cB[i], pbn + p.eps * p11 + tiny
        rs.append(10 * np.log10((pf + tiny) / (pb + tiny)))
        ref = min(min(rs[-win:]), 0.0) if win else 0.0
        if not rs[-1] > ref + p.adapt_gate_db:
            beta = min(max(beta + p.mu * num / den, 0.0), 1.0)
    return np.array(out)


def _gate_test_input(rng, n=3000):
    """Noise at 120 deg throughout (interior beta) and the talker at 45 deg in the second half."""
    x = plane_wave_pair(lowpass_noise(n, cutoff_hz=1000, rng=rng), az_deg=120)
    x[:, n // 2:] += 3 * plane_wave_pair(harmonic_speechlike(n), az_deg=TALKER_AZ)[:, n // 2:]
    return x


@pytest.mark.parametrize("kwargs", [
    {},                                                     # GatedElkoBeamformer defaults (block, 1 s floor)
    {"gate_floor_s": 0.0},                                  # plain 0 dB reference
    {"gate_floor_s": 0.005, "gate_lam": 0.5, "block_len": 7},  # fast, fluctuating ratio: the window matters
    {"update": "sample", "gate_floor_s": 0.001, "gate_lam": 0.5},
    {"update": "sample", "gate_floor_s": 0.0, "adapt_gate_db": 1.0},
])
def test_gated_beta_matches_slow_reference_and_streams(kwargs, rng):
    """Oracle: the plain-Python reference above (beta trajectory within 1e-12).  Streaming in blocks of
    1, 16, 97 == batch (1e-9), replay(mixture) == output; the input has both frozen and adapting steps."""
    e = GatedElkoBeamformer(**kwargs)
    x = _gate_test_input(rng)
    r = e.process(x, FS)
    beta = r.trace["beta"]
    np.testing.assert_allclose(beta, _reference_betas(e, x), rtol=0, atol=1e-12)
    steps = np.diff(beta[:: e.params.block_len if e.params.update == "block" else 1])
    assert np.any(steps == 0) and np.any(steps != 0)
    for block in (1, 16, 97):
        state, parts = e.init_state(FS), []
        for i in range(0, x.shape[-1], block):
            out, state = e.process_block(x[:, i:i + block], state)
            parts.append(out)
        np.testing.assert_allclose(np.concatenate(parts, axis=-1), r.output, rtol=0, atol=1e-9)
    pickle.loads(pickle.dumps(state))
    np.testing.assert_allclose(r.replay(x), r.output, rtol=0, atol=1e-9)


def test_gated_silence_gives_zero():
    r = GatedElkoBeamformer(beta0=0.3).process(np.zeros((2, 1000)), FS)
    assert np.all(r.output == 0) and np.all(r.trace["beta"] == 0.3)
