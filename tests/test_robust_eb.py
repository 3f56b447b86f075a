"""``eb-robust`` (calibration + sub-band EB + noise-aware EQ) and ``eb-robust-ss``.

Oracles: the white-noise-gain bound stated by :mod:`enhancers.core.eq` (output PSD of spatially white sensor
noise <= 10^(eq_noise_gain_db/10) x one mic's, per bin), measured on the running enhancer; the mismatch
applied by ``mismatch.apply_mismatch``; ``ss`` run on ``eb-robust``'s output for the cascade.
"""

from __future__ import annotations

import numpy as np
import pytest
from mismatch import apply_mismatch
from signals import FS, plane_wave_pair

from enhancers.core.chain import Chain
from enhancers.core.eq import look_eq_gain, white_noise_factor
from enhancers.core.registry import make

NFFT = 256


def _psd(y: np.ndarray) -> np.ndarray:
    """Mean periodogram per rfft bin of 256-sample Hann frames (no overlap), ``(129,)``."""
    frames = y[: (y.size // NFFT) * NFFT].reshape(-1, NFFT) * np.hanning(NFFT)
    return np.mean(np.abs(np.fft.rfft(frames, axis=1)) ** 2, axis=0)


@pytest.fixture(scope="module")
def white():
    return np.random.default_rng(31).standard_normal((2, 10 * FS))


@pytest.mark.parametrize("name, kwargs", [("eb-robust", {"das_mix": False}), ("eb-subband", {"eq_noise_gain_db": 9.0})])
def test_self_noise_never_exceeds_the_eq_bound(name, kwargs, white):
    """Spatially white noise alone (independent, unit variance per mic): the output PSD re one mic's stays
    <= 9 dB + 0.5 dB (estimation spread of a 600-frame periodogram average) in every bin, and the bound
    is reached (>= 8 dB somewhere; measured 9.0 / 9.2 dB), so it is what limits the output.  Control:
    without the bound (eq_noise_gain_db=None) some bin exceeds 20 dB (measured 21.6 with eb-robust's
    80 Hz high-pass, 27.3 without)."""
    e = make(name, **kwargs)
    y = e.process(white, FS).output[0, FS:]
    ratio_db = 10 * np.log10(_psd(y)[1:-1] / _psd(white[0, FS:])[1:-1])
    assert ratio_db.max() <= 9.5 and ratio_db.max() >= 8.0, ratio_db.max()
    y_free = make(name, **{**kwargs, "eq_noise_gain_db": None}).process(white, FS).output[0, FS:]
    assert (10 * np.log10(_psd(y_free)[1:-1] / _psd(white[0, FS:])[1:-1])).max() > 20.0


def test_eq_bound_holds_for_every_beta():
    """G(beta)^2 N(beta) <= 10^(nb/10) for random betas (N = 2(1 + beta^2 + 2 beta cos wT), the white-noise
    output of cF - beta cB), and G equals the exact look inverse 1/|2 sin wT| where the bound does not bind."""
    rng = np.random.default_rng(32)
    w = 2 * np.pi * np.arange(129) / NFFT
    beta = rng.uniform(0, 1, (50, 129))
    g = look_eq_gain(beta, omega=w, delay_samples=0.998, freqs_hz=w / (2 * np.pi) * FS, max_gain_db=25.0,
                     noise_gain_db=9.0)
    n = 2 * (1 + beta**2 + 2 * beta * np.cos(w * 0.998))
    np.testing.assert_allclose(white_noise_factor(beta, w * 0.998), n, rtol=1e-12)
    assert np.all(g**2 * n <= 10**0.9 * (1 + 1e-12))
    free = 1 / np.maximum(np.abs(2 * np.sin(w * 0.998)), 1e-30)
    loose = (free**2 * n < 10**0.9) & (free < 10 ** (25 / 20))
    assert loose.sum() > 1000
    np.testing.assert_allclose(g[loose], np.broadcast_to(free, g.shape)[loose], rtol=1e-12)


def test_broadband_white_noise_amplification_re_look_direction():
    """A white plane wave from 0 deg plus white sensor noise 20 dB below it; each replayed alone, second half.
    Amplification of the noise relative to the look direction: eb-robust <= 4.5 dB (measured 3.7; issue 12
    target 6 dB), the fixed cardioid > 10 dB (measured 10.3 here; the issue quotes 10.8)."""
    rng = np.random.default_rng(33)
    n = 6 * FS
    look = plane_wave_pair(rng.standard_normal(n), az_deg=0)
    noise = 0.1 * rng.standard_normal((2, n))

    def amplification(name):
        r = make(name).process(look + noise, FS)
        h = n // 2
        a_noise = np.mean(r.replay(noise)[:, h:] ** 2) / np.mean(noise[0, h:] ** 2)
        a_look = np.mean(r.replay(look)[:, h:] ** 2) / np.mean(look[0, h:] ** 2)
        return 10 * np.log10(a_noise / a_look)

    assert amplification("eb-robust") <= 4.5
    assert amplification("cardioid") > 10.0


def test_robust_nulls_a_mismatched_plane_wave(rng):
    """White noise from 135 deg on mics with 1 dB / 5 deg / high-pass corners 80 and 120 Hz: after 6 s
    (calibration converged), eb-robust's null is >= 30 dB over the last 2 s (look-direction replay over
    output; measured 35.5), while eb-subband without calibration stays < 12 dB (measured 8.1: a real beta
    cannot null a mismatch)."""
    n = 8 * FS
    mism = dict(gain_db=1.0, phase_deg=5.0, highpass_hz=(80.0, 120.0))
    x = apply_mismatch(plane_wave_pair(rng.standard_normal(n), az_deg=135), fs=FS, **mism)
    look = apply_mismatch(plane_wave_pair(rng.standard_normal(n), az_deg=0), fs=FS, **mism)

    def depth(name):
        r = make(name).process(x, FS)
        return 10 * np.log10(np.mean(r.replay(look)[:, 6 * FS:] ** 2) / np.mean(r.output[:, 6 * FS:] ** 2))

    assert depth("eb-robust") >= 30.0
    assert depth("eb-subband") < 12.0


def test_robust_ss_is_robust_then_ss(rng):
    """eb-robust-ss == ss applied to eb-robust's output (to 1e-12); latency is the sum (2 x 255 samples)."""
    x = rng.standard_normal((2, 8000))
    e = make("eb-robust-ss")
    assert isinstance(e, Chain) and e.tags.latency_samples == 2 * 255
    y = make("ss").process(make("eb-robust").process(x, FS).output, FS).output
    np.testing.assert_allclose(e.process(x, FS).output, y, rtol=0, atol=1e-12)


def test_das_fallback_takes_over_in_incoherent_noise(white):
    """Spatially white noise only: where the differential path is >= 4 dB noisier than the look-aligned
    delay-and-sum (closed form N/(2 sin^2 wT) with beta ~0, which holds below 4 kHz: 150 Hz-1.7 kHz) the mix
    weight alpha converges to >= 0.9 (closed form 1; measured >= 0.96), and the output self-noise stays
    <= -2 dB re one mic in every bin (closed form -3 dB for alpha = 1 and look gain <= 1; measured -2.3)."""
    r = make("eb-robust").process(white, FS)
    w_t = 2 * np.pi * np.arange(129) / NFFT * 0.998
    with np.errstate(divide="ignore"):
        diff_over_das_db = 10 * np.log10(2 / (2 * np.sin(w_t) ** 2))
    f = np.arange(129) * FS / NFFT
    band = (diff_over_das_db >= 4.0) & (f >= 150) & (f <= 4000)
    alpha = r.trace["alpha"][FS // 128:].mean(axis=0)
    assert alpha[band].min() >= 0.9, alpha[band].min()
    y = r.output[0, FS:]
    assert (10 * np.log10(_psd(y)[1:-1] / _psd(white[0, FS:])[1:-1])).max() <= -2.0


def test_das_fallback_stays_off_for_a_rear_plane_wave(rng):
    """White noise from 135 deg: the differential null wins, alpha stays <= 0.05 on average in every bin
    from 200 Hz to 6 kHz after 3 s (closed form 0; measured 0.03)."""
    x = plane_wave_pair(rng.standard_normal(6 * FS), az_deg=135)
    alpha = make("eb-robust").process(x, FS).trace["alpha"][3 * FS // 128:].mean(axis=0)
    f = np.arange(129) * FS / NFFT
    band = (f >= 200) & (f <= 6000)
    assert alpha[band].max() <= 0.05


def test_das_fallback_keeps_the_look_response(white):
    """The delay-and-sum path is scaled to the differential path's look response, so a look-direction plane
    wave replayed through eb-subband adapted with alpha ~1 (incoherent noise) matches das_mix=False within
    0.1 dB and 1 deg from 600 Hz to 6 kHz (D = Yd - Yo has no look component for matched mics).  Below
    600 Hz the frame-wise model of the one-sample delay makes the differential path itself deviate from
    its ideal look response (0.6 dB at 200 Hz; see test_subband_eb), which the delay-and-sum does not."""
    n = white.shape[1]
    imp = np.zeros(n)
    imp[n // 2] = 1.0
    look = plane_wave_pair(imp, az_deg=0)
    y_mix = make("eb-subband", das_mix=True, eq_phase=True).process(white, FS).replay(look)[0]
    y_ref = make("eb-subband", eq_phase=True).process(white, FS).replay(look)[0]
    seg = slice(n // 2 - 2048, n // 2 + 2048)
    H = np.fft.rfft(y_mix[seg]) / np.fft.rfft(y_ref[seg])
    f = np.fft.rfftfreq(4096, 1 / FS)
    band = (f >= 600) & (f <= 6000)
    assert np.max(np.abs(20 * np.log10(np.abs(H[band])))) <= 0.1
    assert np.max(np.abs(np.degrees(np.angle(H[band])))) <= 1.0


def test_das_fallback_does_not_learn_from_the_talker(rng):
    """A speech-like talker at 45 deg (its D = Yd - Yo is not zero: 45 deg is not the look direction) over
    spatially white noise 10 dB below it: alpha learns only in bins the calibration does not freeze, so it
    still reaches >= 0.9 on average from 150 Hz to 1.5 kHz after 2 s (measured 0.96; learning in every
    frame instead gives 0.60)."""
    from signals import harmonic_speechlike

    n = 8 * FS
    talk = plane_wave_pair(harmonic_speechlike(n), az_deg=45)
    noise = rng.standard_normal((2, n))
    noise *= np.sqrt(0.1 * np.mean(talk[0] ** 2) / np.mean(noise[0] ** 2))
    alpha = make("eb-robust").process(talk + noise, FS).trace["alpha"][2 * FS // 128:].mean(axis=0)
    f = np.arange(129) * FS / NFFT
    band = (f >= 150) & (f <= 1500)
    assert alpha[band].mean() >= 0.9, alpha[band].mean()


def test_das_fallback_is_not_modulated_by_the_talker(rng):
    """Issue 12 (wind): the mix weight's regulariser is referenced to the *noise* (the average of P_1 over
    the same unfrozen frames), not to the current frame's power, so a loud talker cannot pull alpha away
    from its noise-only estimate.  Speech-like talker at 45 deg with spatially white noise 30 dB below it
    (incoherent noise: closed form alpha = 1): mean alpha from 150 Hz to 1.5 kHz after 2 s >= 0.95 overall
    and in the frames the calibration freezes (talker dominant) -- measured 0.980 / 0.980; regularised by
    eps x the current frame's P_1 instead: 0.89 / 0.88 (the previous estimator, also with prior 0 and per
    bin: 0.79 / 0.76) -- the differential path's amplified noise switched on with every syllable, a
    residual SS cannot track."""
    from signals import harmonic_speechlike

    n = 8 * FS
    talk = plane_wave_pair(harmonic_speechlike(n), az_deg=45)
    noise = rng.standard_normal((2, n))
    noise *= np.sqrt(1e-3 * np.mean(talk[0] ** 2) / np.mean(noise[0] ** 2))
    r = make("eb-robust").process(talk + noise, FS)
    f = np.arange(129) * FS / NFFT
    band = (f >= 150) & (f <= 1500)
    alpha = r.trace["alpha"][2 * FS // 128:][:, band]
    talking = r.trace["frozen"][2 * FS // 128:][:, band].astype(bool)
    assert alpha.mean() >= 0.95, alpha.mean()
    assert alpha[talking].mean() >= 0.95, alpha[talking].mean()


def test_das_fallback_stays_off_for_a_rear_plane_wave_under_a_talker(rng):
    """The other side of the same regulariser: the talker of the test above over white noise from 135 deg,
    40 dB below it (the null wins: closed form alpha = 0).  Mean alpha from 200 Hz to 6 kHz after 3 s
    <= 0.06 overall and in the frames the calibration freezes (measured 0.026 / 0.027).  A regulariser
    referenced to the current frame's P_1 drifts to the prior (alpha0 = 0.5) with every syllable and lets
    the rear noise through: measured 0.23 / 0.24."""
    from signals import harmonic_speechlike

    n = 8 * FS
    talk = plane_wave_pair(harmonic_speechlike(n), az_deg=45)
    noise = plane_wave_pair(rng.standard_normal(n), az_deg=135)
    noise *= np.sqrt(1e-4 * np.mean(talk[0] ** 2) / np.mean(noise[0] ** 2))
    r = make("eb-robust").process(talk + noise, FS)
    f = np.arange(129) * FS / NFFT
    band = (f >= 200) & (f <= 6000)
    alpha = r.trace["alpha"][3 * FS // 128:][:, band]
    talking = r.trace["frozen"][3 * FS // 128:][:, band].astype(bool)
    assert alpha.mean() <= 0.06, alpha.mean()
    assert alpha[talking].mean() <= 0.06, alpha[talking].mean()


def test_das_fallback_starts_from_its_prior():
    """Before any noise-only frame the mix weight is its prior mix_alpha0 exactly: 0.5 in eb-robust (the
    minimax choice for the quadratic output-noise excess (alpha - alpha*)^2 S_DD over alpha* in [0, 1]),
    0 (the differential path) in eb-subband with das_mix; a bin whose averages stay zero (digital silence)
    keeps it (0/0 regularised, no NaN)."""
    x = np.zeros((2, 4 * 256))
    a_robust = make("eb-robust").process(x, FS).trace["alpha"]
    a_sub = make("eb-subband", das_mix=True, eq_phase=True).process(x, FS).trace["alpha"]
    assert np.all(a_robust == 0.5) and np.all(a_sub == 0.0)


def test_eq_bound_beta_fixes_the_equaliser(rng):
    """Issue 16: with ``eq_bound_beta=b`` the noise-aware EQ is the white-noise bound of the fixed pattern
    ``cF - b cB`` (closed form :func:`look_eq_gain` at ``b``) in every frame, whatever beta adapts to, so it
    is the same in the runs on ``s + n`` and ``s - n``; with the default it follows beta (a rear plane wave
    pulls beta up, and the bound with it) and differs between the two runs."""
    from signals import harmonic_speechlike

    n = 3 * FS
    talk = plane_wave_pair(harmonic_speechlike(n), az_deg=45)
    noise = 0.3 * plane_wave_pair(rng.standard_normal(n), az_deg=150)
    w = 2 * np.pi * np.arange(129) / NFFT
    for b in (0.0, 0.7):
        e = make("eb-robust", eq_bound_beta=b)
        eq1, eq2 = (e._step(x, e._init_state(FS))[2]["eq"] for x in (talk + noise, talk - noise))
        closed = look_eq_gain(np.full(129, b), omega=w, delay_samples=e.delay_samples(FS), freqs_hz=w / (2 * np.pi) * FS,
                              max_gain_db=25.0, noise_gain_db=9.0, highpass_hz=80.0)
        np.testing.assert_allclose(np.abs(eq1), np.broadcast_to(closed, eq1.shape), rtol=1e-12)
        assert np.array_equal(eq1, eq2)
    e = make("eb-robust")
    eq1, eq2 = (e._step(x, e._init_state(FS))[2]["eq"] for x in (talk + noise, talk - noise))
    assert np.max(np.abs(np.abs(eq1) - np.abs(eq2))) > 1e-3


def test_eq_bound_beta_is_checked():
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError, match="eq_bound_beta"):
        make("eb-robust", eq_bound_beta=1.5)


def test_das_weight_freezes_on_the_calibrations_masks(rng):
    """With the frame rule the per-bin DAS weight (``mix_model="weights"``) learns only where the calibration's
    masks leave a cell open: it does not move from a frame the calibration's ``frozen`` mask marks (the rule's
    talker frames and the hold after them) to the next, and it does move from the others.  Oracle: the
    weight's one-pole averages stand still exactly where frozen (step 0); a talker burst over white noise."""
    from signals import harmonic_speechlike

    n = 3 * FS
    talk = np.zeros((2, n))
    talk[:, FS:2 * FS] = plane_wave_pair(harmonic_speechlike(FS), az_deg=45)
    tr = make("eb-robust", frame_q_db=5.0).process(talk + 0.1 * rng.standard_normal((2, n)), FS).trace
    frozen = tr["frozen"][:-1].astype(bool)  # the mask the DAS weight uses, frame by frame
    step = np.abs(np.diff(tr["alpha"], axis=0))
    assert frozen.all(axis=1).sum() >= 50  # the burst's voiced frames and their hold (measured 68 frames)
    assert step[frozen].max() == 0.0 and step[~frozen].max() > 1e-6


# the frame rule with the DAS weight learned, 0.24 s late, where the calibration learns
FRAME_DELAYED = {"frame_q_db": 5.0, "level_hang_s": 0.2, "level_ahead_s": 0.24,
                 "mix_model": "delayed", "mix_bands_hz": (1000.0, 4000.0), "mix_alpha0": 1.0}


def _bursts(seed):
    """``(s, n)``: a 45 deg talker 20 dB over white diffuse-free noise (independent per mic), 1-1.5 s and
    3-3.5 s, exactly zero elsewhere; 5 s."""
    from signals import harmonic_speechlike

    rng = np.random.default_rng(seed)
    n = 5 * FS
    noise = rng.standard_normal((2, n))
    on = ((np.arange(n) >= FS) & (np.arange(n) < int(1.5 * FS))) | ((np.arange(n) >= 3 * FS) & (np.arange(n) < int(3.5 * FS)))
    talk = plane_wave_pair(harmonic_speechlike(n, pause_s=0.5), az_deg=45) * on
    return talk * np.sqrt(100 / np.mean(talk[0, on] ** 2)), noise


@pytest.mark.parametrize("mix_model, same", [("delayed", True), ("weights", False)])
def test_delayed_das_weight_ignores_the_talker(mix_model, same):
    """Issue 16: with ``mix_model="delayed"`` the DAS weight adapted on ``s + n`` and on ``s - n`` is the same
    through the first burst and the frame rule's hold after it (oracle: the mixtures are identical up to sign
    where the talker is absent, and the weight learns only where the calibration does, 0.24 s late, so to
    1e-12).  Control: the weight learned at once on the calibration's causal masks (``"weights"``) moves with
    the talker's onset, before the rule has seen it (differs by > 1e-6 in that span)."""
    s, n = _bursts(41)
    params = {**FRAME_DELAYED, "mix_model": mix_model}
    a1, a2 = (make("eb-robust", **params).process(x, FS).trace["alpha"] for x in (s + n, s - n))
    m = int(1.75 * FS / 128)
    diff = np.max(np.abs(a1[:m] - a2[:m]))
    assert (diff < 1e-12) if same else (diff > 1e-6), diff


def test_delayed_das_weight_closed_forms(white, rng):
    """The delayed weight keeps the least-squares closed forms: spatially white noise, alpha -> 1 in the band
    1-4 kHz where the differential path is noisier than the DAS (measured >= 0.984 after 3 s; tolerance 0.05,
    the one-pole's estimation spread over ~350 learned frames of 48 bins); white noise from 135 deg, alpha -> 0 (the
    null wins, and the weight is clipped at 0: measured 0.0) in the bands 0-1 and 1-4 kHz."""
    a = make("eb-robust", **FRAME_DELAYED).process(white[:, :6 * FS], FS).trace["alpha"][3 * FS // 128:]
    f = np.arange(129) * FS / NFFT
    assert a[:, (f >= 1000) & (f < 4000)].min() >= 0.95
    x = plane_wave_pair(rng.standard_normal(6 * FS), az_deg=135)
    a = make("eb-robust", **FRAME_DELAYED).process(x, FS).trace["alpha"][3 * FS // 128:]
    assert a[:, (f >= 100) & (f < 4000)].max() <= 0.01


def test_delayed_das_weight_streams_as_one_pass():
    """Blocks of 1, 7, 160 and 999 samples give the one-pass output (the pending products and the frame rule's
    state are carried).  Oracle: the same computation, to 1e-12 of the peak."""
    s, n = _bursts(42)
    _assert_streams_as_one_pass(make("eb-robust", **FRAME_DELAYED), s + n)


def _assert_streams_as_one_pass(e, x):
    """``e`` in blocks of 1, 7, 160 and 999 samples gives its one-pass output on ``x``, to 1e-12 of the peak."""
    whole = e.process(x, FS).output
    state, parts, lo, sizes = e.init_state(FS), [], 0, [1, 7, 160, 999]
    i = 0
    while lo < x.shape[1]:
        hi = min(x.shape[1], lo + sizes[i % len(sizes)])
        out, state = e.process_block(x[:, lo:hi], state)
        parts.append(out)
        lo, i = hi, i + 1
    streamed = np.concatenate(parts, axis=1)
    k = min(streamed.shape[1], whole.shape[1])
    np.testing.assert_allclose(streamed[:, :k], whole[:, :k], rtol=0, atol=1e-12 * np.abs(whole).max())


@pytest.mark.parametrize("name, bad", [("eb-robust", {"mix_model": "delayed"}),
                                       ("eb-robust", {**FRAME_DELAYED, "calibrate": False}),
                                       ("eb-subband", {"mix_model": "delayed", "mix_bands_hz": (1000.0,)}),
                                       ("eb-robust", {"mix_model": "covariance"})])
def test_delayed_das_weight_parameters_are_checked(name, bad):
    """The delayed weight is pooled per band and learns where eb-robust's calibration does: without
    ``mix_bands_hz`` or without the calibration it is a one-line parameter error."""
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError):
        make(name, **bad)


def test_fast_start_stands_in_for_the_delayed_weight(rng):
    """``mix_fast_cells``: a rear plane wave from the first sample (a machine already running): the delayed weight
    has nothing to learn from before 0.24 s and holds its prior 1 (the DAS), the weight learned at once already
    favours the null (closed form alpha* = 0; measured <= 0.03 from frame 10); once the delayed weight has the
    cells it is the delayed weight exactly (oracle: the same accumulators, to 1e-12)."""
    x = plane_wave_pair(rng.standard_normal(3 * FS), az_deg=150)
    slow = make("eb-robust", **FRAME_DELAYED).process(x, FS).trace["alpha"]
    fast = make("eb-robust", **FRAME_DELAYED, mix_fast_cells=500.0).process(x, FS).trace["alpha"]
    f = np.arange(129) * FS / NFFT
    band = (f >= 100) & (f < 4000)
    assert slow[10:25, band].min() == 1.0 and fast[10:25, band].max() <= 0.05
    late = int(1.5 * FS / 128)
    np.testing.assert_allclose(fast[late:], slow[late:], rtol=0, atol=1e-12)


def test_fast_blend_hands_over_linearly_in_the_learned_cells(rng):
    """``fast_blend``: the DAS weight is ``quick + min(1, n / 500) (delayed - quick)``, ``n`` the delayed weight's
    learned cells of the band.  Closed form for a rear plane wave: every frame is learned from the delayed
    weight's first (frame D = 30, the look ahead) on, so ``n = (t - 30) K_b`` at frame ``t``, ``K_b`` = 16 / 48 /
    65 bins below 1 kHz / 1-4 kHz / above.  With the stand-in's trace (``mix_fast_cells`` huge) and the delayed
    one's (no stand-in), the blend is that formula to 1e-12 in every bin; without ``fast_blend`` it is more
    than 0.01 off (the switch at 500 cells)."""
    x = plane_wave_pair(rng.standard_normal(3 * FS), az_deg=150)

    def alpha(**kw):
        return make("eb-robust", **FRAME_DELAYED, **kw).process(x, FS).trace["alpha"]

    quick, late = alpha(mix_fast_cells=1e9), alpha(mix_fast_cells=0.0)
    f = np.arange(129) * FS / NFFT
    n_bins = np.where(f < 1000, 16, np.where(f < 4000, 48, 65))
    t = np.arange(quick.shape[0])[:, None]
    formula = quick + np.clip((t - 30) * n_bins / 500, 0.0, 1.0) * (late - quick)
    np.testing.assert_allclose(alpha(mix_fast_cells=500.0, fast_blend=True), formula, rtol=0, atol=1e-12)
    assert np.abs(alpha(mix_fast_cells=500.0) - formula).max() > 0.01


# beta as least squares on the calibration's held weights, 0.24 s late
FRAME_BETA = {**FRAME_DELAYED, "beta_model": "delayed"}


def _beta_and_held(x, **params):
    """``eb-robust``'s beta trace over ``x`` and the calibration's held weights it learned with, ``(F, K)`` each."""
    import enhancers.beam.robust_eb as rb

    seen = []
    original = rb.calibration_masks_step

    def spy(*a, **k):
        out = original(*a, **k)
        seen.extend(k["learn_out"] or [])
        return out

    rb.calibration_masks_step = spy
    try:
        beta = make("eb-robust", **params).process(x, FS).trace["beta"]
    finally:
        rb.calibration_masks_step = original
    return beta, np.concatenate([held for held, _ in seen])


@pytest.mark.parametrize("beta_model, same", [("delayed", True), ("bin", False)])
def test_delayed_beta_ignores_the_talker(beta_model, same):
    """``beta_model="delayed"``: beta adapted on ``s + n`` and on ``s - n`` is the same through the first burst
    and the frame rule's hold after it.  Oracle as for the delayed DAS weight: the mixtures are identical up to
    sign where the talker is absent, beta learns only the frames the calibration's held weights open, 0.24 s
    late, and those weights are the same in both runs here (asserted: where the talker's first frame
    straddles the rule's threshold, the talker x noise cross term can move the look ahead's edge by a frame,
    and another noise-only frame is learned -- with seed 44, 0.8 s), so to 1e-12.  Control: the per-bin NLMS
    on its own gate (``"bin"``) learns from the talker's onsets the gate lets through
    (differs by > 1e-6)."""
    s, n = _bursts(41)
    params = {**FRAME_DELAYED, "beta_model": beta_model, "mu": 0.1}
    (b1, h1), (b2, h2) = (_beta_and_held(x, **params) for x in (s + n, s - n))
    m = int(1.75 * FS / 128)
    np.testing.assert_array_equal(h1[:m], h2[:m])
    diff = np.max(np.abs(b1[:m] - b2[:m]))
    assert (diff < 1e-12) if same else (diff > 1e-6), diff


def test_delayed_beta_nulls_a_rear_plane_wave(rng):
    """Closed form (eq. 1): for one plane wave the forward and backward cardioids are real multiples of each
    other, so the least-squares beta is :func:`enhancers.beam.subband_eb.closed_form_beta` in every bin.  White noise
    from 135 deg: within 0.03 of it over 500 Hz-4 kHz from 1 s on (measured 0.024, at 500 Hz, where the
    frame's window leaks; the per-bin NLMS measures the same 0.024).  Before the look ahead has passed
    beta is ``beta0`` exactly: the filter bank's first, partial frame is not learned, and a frame is learned 30
    frames (0.24 s) after it, when it has been judged, and applied from the next: beta moves first at frame
    1 + 30 + 1 = 32."""
    from enhancers.beam.subband_eb import closed_form_beta

    x = plane_wave_pair(rng.standard_normal(3 * FS), az_deg=135)
    e = make("eb-robust", **FRAME_BETA, beta0=0.5)
    beta = e.process(x, FS).trace["beta"]
    f = np.arange(129) * FS / NFFT
    ref = closed_form_beta(135.0, 2 * np.pi * f / FS * e.delay_samples(FS))
    band = (f >= 500) & (f <= 4000)
    assert np.abs(beta[FS // 128:, band] - ref[band]).max() <= 0.03
    assert np.all(beta[:32] == 0.5) and np.any(beta[32] != 0.5)


def test_fast_start_stands_in_for_the_delayed_beta(rng):
    """``beta_fast_frames``: a rear plane wave from the first sample: until the delayed beta has learned 10
    frames of a bin, a beta learned at once on the frames before the talker is first heard stands in -- within
    0.02 of the closed form over frames 12-31 (measured 0.016), where the delayed one still holds ``beta0`` --
    and from then on beta is the delayed one exactly (the same accumulators, to 1e-12)."""
    from enhancers.beam.subband_eb import closed_form_beta

    x = plane_wave_pair(rng.standard_normal(3 * FS), az_deg=135)
    e = make("eb-robust", **FRAME_BETA, beta0=0.5)
    slow = e.process(x, FS).trace["beta"]
    fast = make("eb-robust", **FRAME_BETA, beta0=0.5, beta_fast_frames=10.0).process(x, FS).trace["beta"]
    f = np.arange(129) * FS / NFFT
    ref = closed_form_beta(135.0, 2 * np.pi * f / FS * e.delay_samples(FS))
    band = (f >= 500) & (f <= 4000)
    assert np.abs(fast[12:32, band] - ref[band]).max() <= 0.02 and np.all(slow[12:32] == 0.5)
    late = int(1.5 * FS / 128)
    np.testing.assert_allclose(fast[late:], slow[late:], rtol=0, atol=1e-12)


def test_fast_blend_hands_over_beta_linearly_in_the_learned_frames(rng):
    """``fast_blend`` for the delayed beta: ``quick + min(1, n / 10) (delayed - quick)``, ``n`` the bin's learned
    frames.  Closed form for a rear plane wave (every frame learned by every bin from the first full frame on,
    which reaches the delayed average at frame 1 + 30): ``n = t - 31``; to 1e-12, and more than 0.01 off
    without the blend."""
    x = plane_wave_pair(rng.standard_normal(3 * FS), az_deg=135)

    def beta(**kw):
        return make("eb-robust", **FRAME_BETA, beta0=0.5, **kw).process(x, FS).trace["beta"]

    quick, late = beta(beta_fast_frames=1e9), beta(beta_fast_frames=0.0)
    t = np.arange(quick.shape[0])[:, None]
    formula = quick + np.clip((t - 31) / 10, 0.0, 1.0) * (late - quick)
    np.testing.assert_allclose(beta(beta_fast_frames=10.0, fast_blend=True), formula, rtol=0, atol=1e-12)
    assert np.abs(beta(beta_fast_frames=10.0) - formula).max() > 0.01


def test_delayed_beta_streams_as_one_pass():
    """Blocks of 1, 7, 160 and 999 samples give the one-pass output with the delayed beta and the start-up
    stand-ins (the pending cardioids, the frames seen and every accumulator are
    carried).  Oracle: the same
    computation, to 1e-12 of the peak."""
    s, n = _bursts(45)
    _assert_streams_as_one_pass(make("eb-robust", **FRAME_BETA, beta_fast_frames=10.0, mix_fast_cells=500.0),
                                s + n)


@pytest.mark.parametrize("name, bad", [("eb-robust", {"beta_model": "delayed"}),
                                       ("eb-robust", {**FRAME_BETA, "calibrate": False}),
                                       ("eb-subband", {"beta_model": "delayed"}),
                                       ("eb-robust", {**FRAME_BETA, "beta_lam": 1.0}),
                                       ("eb-robust", {**FRAME_BETA, "beta_fast_frames": -1.0}),
                                       ("eb-robust", {**FRAME_BETA, "mix_fast_ramp_cells": -1.0}),
                                       ("eb-robust", {**FRAME_BETA, "fast_blend": "yes"}),
                                       ("eb-robust", {**FRAME_BETA, "beta_model": "direction"})])
def test_delayed_beta_parameters_are_checked(name, bad):
    """The delayed beta learns where eb-robust's talker-blind calibration does: without it (or with a bad
    average factor or stand-in length, or a beta model that is not there) it is a one-line parameter error."""
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError):
        make(name, **bad)


def test_fast_stand_in_has_its_own_ramp(rng):
    """``mix_fast_ramp_cells``: the DAS weight's stand-in shrinks towards its prior with its own length.  Closed
    form: a rear plane wave from the start (least-squares weight 0, clipped) and the prior 1, so the stand-in at
    frame ``i`` is ``1 - min(1, n_i / R)`` with ``n_i = 48 i`` the cells of the 1-4 kHz band learned before it
    (R = 2000; to 1e-12 over the first 60 frames); and it is the same weight as with ``mix_ramp_cells=R`` and
    no own length (the stand-in used throughout, ``mix_fast_cells`` huge)."""
    x = plane_wave_pair(rng.standard_normal(2 * FS), az_deg=150)
    base = {**FRAME_DELAYED, "mix_fast_cells": 1e9}
    own = make("eb-robust", **base, mix_ramp_cells=1e9, mix_fast_ramp_cells=2000.0).process(x, FS).trace["alpha"]
    shared = make("eb-robust", **base, mix_ramp_cells=2000.0).process(x, FS).trace["alpha"]
    np.testing.assert_array_equal(own, shared)
    i = np.arange(60)
    np.testing.assert_allclose(own[:60, 40], 1.0 - np.minimum(1.0, 48 * i / 2000.0), rtol=0, atol=1e-12)
