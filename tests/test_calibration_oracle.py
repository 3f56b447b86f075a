"""The oracle bound of issue 16 part 3 (benchmarks/studies/calibration_oracle.py).

Oracle of the main test: in cells where the talker is exactly absent, the mixtures ``s + n`` and
``s - n`` are the same up to sign, so a calibration that learns only there must give the *same*
estimate in both runs, bit for bit (its averages are products of two spectra).
"""

import numpy as np
import pytest

import enhancers
import enhancers.beam.mic_calibration as mc
import enhancers.beam.subband_eb as sb
from benchmarks.studies.calibration_oracle import oracle_learning, oracle_mask, oracle_params
from enhancers.kernels import frames as fast_frames

FS = 16000


def _burst_scene(seed=0, seconds=3.0):
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    noise = rng.standard_normal((2, n))
    noise[1] = 0.8 * noise[0] + 0.6 * noise[1]  # partly coherent, as diffuse noise is at low frequencies
    speech = np.zeros((2, n))
    lo, hi = n // 3, n // 2
    burst = 3.0 * rng.standard_normal(hi - lo)  # +10 dB over the noise, the same at both mics
    speech[:, lo:hi] = burst
    return speech, noise


def _estimates(e, x):
    tr = e.process(x, FS).trace
    return tr["rear_gain_db"], tr["rear_phase_deg"]


def test_oracle_calibration_is_the_same_in_both_hagerman_runs():
    s, n = _burst_scene()
    e = enhancers.make("eb-robust", **oracle_params("calibration"))
    mask = oracle_mask(s, n, e.filterbank, -40.0)
    assert 0.05 < mask.mean() < 0.5  # the burst's cells, and only those, are kept out
    with oracle_learning(mask, calibration_only=True):
        g1, p1 = _estimates(e, s + n)
        g2, p2 = _estimates(e, s - n)
    assert np.array_equal(g1, g2) and np.array_equal(p1, p2)
    # the same calibration with its own (blind) rules is moved by the talker: the oracle is what decides
    g3, p3 = _estimates(e, s + n)
    g4, p4 = _estimates(e, s - n)
    assert np.max(np.abs(p3 - p4)) > 0.1


def test_oracle_beta_and_das_weight_are_the_same_in_both_hagerman_runs():
    """``--scope all``: beta and the DAS weight learn on the oracle's cells too, so through the burst (up to the
    frame after its last masked one) both runs' beta and DAS weight are bit for bit the same (oracle as above;
    later their normalisers, smoothed over every frame, still hold the talker's cross term: measured <= 0.035
    after it).  Control: the calibration-only oracle leaves them on their own gate, which the talker moves
    within the burst (> 0.1; measured 0.76 / 0.91)."""
    s, n = _burst_scene()
    traces = {}
    for scope in ("all", "calibration"):
        e = enhancers.make("eb-robust", **oracle_params(scope))
        mask = oracle_mask(s, n, e.filterbank, -40.0)
        with oracle_learning(mask, calibration_only=scope == "calibration"):
            traces[scope] = [e.process(x, FS).trace for x in (s + n, s - n)]
    burst = slice(0, np.nonzero(mask.any(axis=1))[0][-1] + 2)
    (t1, t2), (c1, c2) = traces["all"], traces["calibration"]
    for key in ("beta", "alpha"):
        assert np.array_equal(t1[key][burst], t2[key][burst]), key
        assert np.max(np.abs(c1[key][burst] - c2[key][burst])) > 0.1, key


def test_oracle_learning_restores_the_freeze_rules():
    original, beamform, compiled = mc._freeze, sb.SubbandBase._beamform, fast_frames.COMPILED
    with pytest.raises(RuntimeError), oracle_learning(np.zeros((10, 129), dtype=bool)):
        assert mc._freeze is not original and sb.SubbandBase._beamform is not beamform  # the oracle's rules
        assert fast_frames.COMPILED is False  # the numpy step, which has the hooks
        raise RuntimeError
    # and the calibration's and the beamformer's own again after it, even after an error
    assert mc._freeze is original and sb.SubbandBase._beamform is beamform and fast_frames.COMPILED is compiled


def test_oracle_mask_thresholds_the_talker_to_noise_ratio_per_cell():
    rng = np.random.default_rng(3)
    n = rng.standard_normal((2, 8192))
    e = enhancers.make("eb-robust")
    for ratio_db in (-30.0, -10.0):
        s = 10 ** (ratio_db / 20) * rng.standard_normal((2, 8192))
        # per-cell ratios scatter around ratio_db (two chi-square(4) powers): a threshold 20 dB below it keeps
        # almost every cell out, one 20 dB above it almost none
        assert oracle_mask(s, n, e.filterbank, ratio_db - 20.0)[4:-4].mean() > 0.95
        assert oracle_mask(s, n, e.filterbank, ratio_db + 20.0)[4:-4].mean() < 0.05


def test_bad_set_is_one_line_not_a_traceback(capsys):
    from benchmarks.studies.calibration_oracle import main

    with pytest.raises(SystemExit) as exc:
        main(["--set", "mu=x"])
    assert exc.value.code == 2 and "--set 'mu=x'" in capsys.readouterr().err.strip().splitlines()[-1]


def test_frame_oracle_decides_whole_frames():
    """``frame=True``: every bin of a frame gets the decision of the frame's talker-to-noise ratio over
    125 Hz-4 kHz.  A "talker" of independent white noise 20 dB below the noise: per cell the two mics'
    summed periodograms are Gamma(2) each, so their ratio exceeds 10x its mean with probability
    1 - I_{10/11}(2, 2) = 2.3 % (closed form; measured 2.6 %): at -10 dB that many cells are not learned.
    Summed over the band's 62 bins the ratio is -20 dB +- ~1 dB, so at -10 dB no frame is frozen and at -25
    dB every frame is, in every bin."""
    import numpy as np

    from benchmarks.studies.calibration_oracle import oracle_mask
    from enhancers.core.filterbank import FilterBank

    fb = FilterBank(frame_len=256, hop=128)
    rng = np.random.default_rng(3)
    n = rng.standard_normal((2, 16384))
    s = 0.1 * rng.standard_normal((2, 16384))
    inner = slice(3, -3)  # frames with a whole window of signal
    assert 0.015 < oracle_mask(s, n, fb, -10.0)[inner].mean() < 0.035
    assert not oracle_mask(s, n, fb, -10.0, frame=True)[inner].any()
    assert oracle_mask(s, n, fb, -25.0, frame=True)[inner].all()
