"""Sub-band Elko beamformer (``eb-subband``) against the exact two-mic plane-wave response.

Oracles: the per-bin closed form ``beta_k = sin(w T (1 + c)/2) / sin(w T (1 - c)/2)`` (algorithms.md
section 5, written out here, not imported), the exact response ``sin(wT(1+c)/2) - beta sin(wT(1-c)/2)``,
and a slow loop reference of the per-bin NLMS (tests/subband_reference.py).  Plane waves come from
``signals.plane_wave_pair`` (exact FFT delays), mismatches from ``mismatch.apply_mismatch``.
"""

from __future__ import annotations

import numpy as np
import pytest
from mismatch import apply_mismatch
from signals import C_MPS, FS, SPACING_M, plane_wave_pair
from subband_reference import subband_beta_reference

from enhancers.beam.subband_eb import SubbandElkoBeamformer, subband_beta_step, subband_init
from enhancers.core.registry import make

N = 4 * FS
HALF = N // 2
NFFT = 256
T_FS = SPACING_M / C_MPS * FS
K = np.arange(NFFT // 2 + 1)
WT = 2 * np.pi * K / NFFT * T_FS
F_HZ = K * FS / NFFT


def _closed_form_beta(theta_deg):
    c = np.cos(np.radians(theta_deg))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sin(WT * (1 + c) / 2) / np.sin(WT * (1 - c) / 2)


def _null_depth_db(result, look, n_from=HALF):
    return 10 * np.log10(np.mean(result.replay(look)[:, n_from:] ** 2) / np.mean(result.output[:, n_from:] ** 2))


@pytest.fixture(scope="module")
def adapted():
    """eb-subband adapted to 4 s of white noise from 120, 135 and 150 deg (ideal mics)."""
    rng = np.random.default_rng(11)
    out = {}
    for theta in (120, 135, 150):
        x = plane_wave_pair(rng.standard_normal(N), az_deg=theta)
        out[theta] = (x, SubbandElkoBeamformer().process(x, FS))
    return out


@pytest.mark.parametrize("theta", [120, 135, 150])
def test_per_bin_beta_matches_closed_form(theta, adapted):
    """Mean beta over the second half within 0.02 of the closed form in every bin from 200 Hz to 7 kHz."""
    _, r = adapted[theta]
    beta = r.trace["beta"][r.trace["beta"].shape[0] // 2:].mean(axis=0)
    band = (F_HZ >= 200) & (F_HZ <= 7000)
    err = np.abs(beta[band] - _closed_form_beta(theta)[band])
    assert err.max() <= 0.02, (F_HZ[band][err.argmax()], err.max())


@pytest.mark.parametrize("theta", [120, 135, 150])
def test_broadband_null_depth_at_least_30_db(theta, adapted):
    """Issue 12 target: white noise from one rear plane wave is nulled by >= 30 dB broadband (measured 31.6-33.3;
    the scalar-beta eb reaches 10.8 / 11.4 / 16.0 dB here)."""
    x, r = adapted[theta]
    look = plane_wave_pair(np.random.default_rng(12).standard_normal(N), az_deg=0)
    assert _null_depth_db(r, look) >= 30.0


@pytest.mark.parametrize("probe", [0.0, 90.0, 180.0])
def test_per_bin_response_matches_exact_plane_wave_response(probe, adapted):
    """With the adapted betas, the output PSD of a white plane wave from ``probe`` relative to one from 60 deg
    follows the frame average of |sin(wT(1+c)/2) - beta_l sin(wT(1-c)/2)|^2 per bin within 0.2 dB
    (600 Hz-6 kHz where the response is >= -20 dB re 60 deg; measured <= 0.16 dB there.  Below ~600 Hz the
    frame-wise model of a one-sample delay loses accuracy against the small differential response:
    0.57 dB at 312 Hz for the 180 deg probe)."""
    _, r = adapted[135]
    beta = r.trace["beta"][r.trace["beta"].shape[0] // 2:]
    rng = np.random.default_rng(13)
    s = rng.standard_normal(N)

    def psd(az):
        y = r.replay(plane_wave_pair(s, az_deg=az))[0, HALF:]
        frames = y[: (y.size // NFFT) * NFFT].reshape(-1, NFFT) * np.hanning(NFFT)
        return np.mean(np.abs(np.fft.rfft(frames, axis=1)) ** 2, axis=0)

    def exact(az):
        c = np.cos(np.radians(az))
        return np.mean(np.abs(np.sin(WT * (1 + c) / 2) - beta * np.sin(WT * (1 - c) / 2)) ** 2, axis=0)

    band = (F_HZ >= 600) & (F_HZ <= 6000)
    measured = 10 * np.log10(psd(probe)[band] / psd(60.0)[band])
    expected = 10 * np.log10(exact(probe)[band] / exact(60.0)[band])
    band = expected >= -20
    assert band.sum() >= 40
    np.testing.assert_allclose(measured[band], expected[band], atol=0.2)


def test_real_beta_cannot_null_a_mismatched_plane_wave(rng):
    """A 5 deg phase mismatch is not a direction: the per-bin beta converges to the real least-squares
    value clip(Re(cF cB*) / |cB|^2, 0, 1) of the mismatched pair (closed form, within 0.03, 300 Hz-7 kHz)
    and the null is far shallower than the 30 dB of matched mics (< 20 dB)."""
    x = apply_mismatch(plane_wave_pair(rng.standard_normal(N), az_deg=135), fs=FS, phase_deg=5.0)
    r = SubbandElkoBeamformer().process(x, FS)
    c = np.cos(np.radians(135))
    rr = np.exp(1j * np.radians(5.0))
    p1 = np.exp(1j * WT * c / 2)
    p2 = rr * np.exp(-1j * WT * c / 2)
    ph = np.exp(-1j * WT)
    cF, cB = p1 - ph * p2, p2 - ph * p1
    with np.errstate(divide="ignore", invalid="ignore"):
        beta_ls = np.clip((cF * np.conj(cB)).real / np.abs(cB) ** 2, 0, 1)
    beta = r.trace["beta"][r.trace["beta"].shape[0] // 2:].mean(axis=0)
    band = (F_HZ >= 300) & (F_HZ <= 7000)
    assert np.max(np.abs(beta[band] - beta_ls[band])) <= 0.03
    look = apply_mismatch(plane_wave_pair(rng.standard_normal(N), az_deg=0), fs=FS, phase_deg=5.0)
    assert _null_depth_db(r, look) < 20.0


@pytest.mark.parametrize("gate", [None, (3.0, 0.8, 7)])
def test_vectorised_update_matches_slow_reference(gate, rng):
    """subband_beta_step (vectorised over bins, in two blocks) == the loop reference to 1e-12."""
    F, Kb = 60, 9
    cB = rng.standard_normal((F, Kb)) + 1j * rng.standard_normal((F, Kb))
    # per-bin least-squares betas from -0.5 to 1.5: the clip acts at both ends
    cF = np.linspace(-0.5, 1.5, Kb) * cB + 0.3 * (rng.standard_normal((F, Kb)) + 1j * rng.standard_normal((F, Kb)))
    cF[20:30, :4] *= 10.0  # a loud "frontal" burst in a few bins, so the gate acts
    X1 = rng.standard_normal((F, Kb)) + 1j * rng.standard_normal((F, Kb))
    kw = dict(mu=0.3, lam=0.8, eps=1e-3)
    gate_kw = {} if gate is None else dict(gate_db=gate[0], gate_lam=gate[1], gate_window=gate[2])
    ref_kw = {} if gate is None else dict(gate_db=gate[0], gate_lam=gate[1], n_window=gate[2])
    expected = subband_beta_reference(cF, cB, X1, beta0=0.2, **kw, **ref_kw)
    state = subband_init(Kb, 0.2)
    a, state = subband_beta_step(cF[:23], cB[:23], X1[:23], state, **kw, **gate_kw)
    b, state = subband_beta_step(cF[23:], cB[23:], X1[23:], state, **kw, **gate_kw)
    got = np.concatenate([a, b])
    assert np.any(expected == 0.0) and np.any(expected == 1.0)  # the clip is exercised at both ends
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name, kwargs", [
    ("eb-subband", dict(adapt_gate_db=3.0, gate_floor_s=0.1)),
    ("eb-robust", dict(mix_bands_hz=(), mix_ramp_cells=100.0)),  # the pooled DAS weight (enhancers.beam.beam_pool)
])
def test_gated_streaming_equals_batch(name, kwargs, rng):
    """With the per-bin gate on (or the pooled DAS weight), blocks of 1, 97 and 128 samples equal batch to 1e-9
    (conformance runs defaults)."""
    e = make(name, **kwargs)
    x = rng.standard_normal((2, 3000))
    y = e.process(x, FS).output
    for block in (1, 97, 128):
        state, parts = e.init_state(FS), []
        for i in range(0, x.shape[1], block):
            out, state = e.process_block(x[:, i:i + block], state)
            parts.append(out)
        np.testing.assert_allclose(np.concatenate(parts, axis=1), y, rtol=0, atol=1e-9)


def test_look_direction_equalised_flat_and_undistorted():
    """Impulse plane wave from 0 deg: the exact look equaliser gives 0 dB within 0.5 dB from 150 Hz to 7 kHz,
    and with eq_phase the phase is that of the front mic delayed by latency + T (255 + 0.998 samples)
    within 5 deg there (measured 2.3 deg; no 90 deg shift)."""
    n = 16384
    imp = np.zeros(n)
    imp[4000] = 1.0
    x = plane_wave_pair(imp, az_deg=0)
    y = make("eb-subband", eq_phase=True).process(x, FS).output[0]
    H = np.fft.rfft(y) / np.fft.rfft(x[0])
    f = np.fft.rfftfreq(n, 1 / FS)
    band = (f >= 150) & (f <= 7000)
    h_db = 20 * np.log10(np.abs(H))
    assert np.all(np.abs(h_db[band]) <= 0.5), (h_db[band].min(), h_db[band].max())
    phase_err = np.angle(H * np.exp(2j * np.pi * f / FS * (255 + T_FS)))
    assert np.max(np.abs(np.degrees(phase_err[band]))) <= 5.0
