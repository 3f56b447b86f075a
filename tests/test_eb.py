"""Elko's adaptive differential beamformer and the fixed patterns, against exact oracles.

Plane waves come from ``signals.plane_wave_pair`` (exact FFT-domain delays), independent of the
project's fractional-delay filters.  Default pair: d = 0.0214 m, c = 343 m/s, fs = 16 kHz (T fs = 0.998).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from signals import C_MPS, FS, SPACING_M, cardioid_pair, lowpass_noise, plane_wave_pair

from enhancers.eb import ElkoBeamformer, FixedCardioid, FixedHypercardioid
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


@pytest.mark.parametrize("make", [lambda: ElkoBeamformer(), lambda: ElkoBeamformer(update="sample"),
                                  lambda: FixedHypercardioid()])
def test_streaming_equals_batch_and_replay_is_exact(make, rng):
    """Blocks of 1, 16, 97, 128 samples == batch (1e-9); replay(mixture) == output; replay is linear."""
    e = make()
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
])
def test_bad_params_name_the_field(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        ElkoBeamformer(**kwargs)


def test_params_json_round_trip():
    p = ElkoBeamformer.Params(mu=0.1, update="sample", eq_hf=0.5)
    assert ElkoBeamformer.Params.from_json(p.to_json()) == p
    assert FixedHypercardioid.Params().beta == 0.5 and FixedCardioid.Params().beta == 0.0
