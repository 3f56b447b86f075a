"""Issue 32 part 1: ``scenesim enhance`` removes the latency and records it; ``scenesim score`` aligns.

Oracles: the undelayed pair scored by :func:`benchmarks.metrics.scoring.score` on the same float64
samples (a delayed copy, once aligned, is the same arrays: equality is exact), and the Python
API's own output of the enhancer advanced by its declared latency.
"""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest
import soundfile as sf
from _wav_headers import wav_with_rate

from benchmarks.cli.main import main
from benchmarks.metrics.align import (
    COMMENT_LIMIT,
    align_pair,
    declared_delay,
    enhance_comment,
    read_enhance_record,
)
from benchmarks.metrics.scoring import INTRUSIVE, NON_INTRUSIVE, score, score_files
from data_recipes.artificial_voice import artificial_voice
from enhancers.core.registry import make
from scenesim.audio import write_audio

FS = 16000
METRICS = (*INTRUSIVE, *NON_INTRUSIVE)


@pytest.fixture(scope="module")
def speech():
    """3 s of the built-in artificial voice at -26 dBFS and a noisy copy at 10 dB (seeds 0, 1)."""
    s, _ = artificial_voice(3.0, fs=FS, seed=0)
    s = 0.05 * s / np.std(s)
    noisy = s + 0.05 * 10 ** (-10 / 20) * np.random.default_rng(1).standard_normal(s.size)
    return s, noisy


def _wav(path, x, comment=None):
    write_audio(path, x, FS, subtype="DOUBLE", comment=comment)
    return path


def _csv(text):
    return list(csv.DictReader(io.StringIO(text)))


def _values(row):
    return {k: row[k] for k in METRICS}


@pytest.mark.parametrize("delay, dnsmos", [(1, False), (37, None), (800, False)])
def test_every_metric_of_a_delayed_copy_equals_the_undelayed(tmp_path, speech, delay, dnsmos):
    """Positive lag (output late, its tail kept) and negative lag (reference late): after the
    cross-correlation alignment every metric equals the undelayed pair's exactly (same float64
    samples); the lag column says +delay / -delay; --no-align really costs SI-SDR (> 1 dB; 2.1 dB at
    one sample).  DNSMOS (where installed) in one case only: it is the slowest metric."""
    s, noisy = speech
    want = score(noisy, FS, reference=s, dnsmos=dnsmos)
    ref = _wav(tmp_path / "ref.wav", s)
    late = _wav(tmp_path / "late.wav", np.concatenate([np.zeros(delay), noisy]))
    early_ref = _wav(tmp_path / "ref_late.wav", np.concatenate([np.zeros(delay), s]))
    early = _wav(tmp_path / "early.wav", noisy)
    (row,) = score_files([late], ref, dnsmos=dnsmos)
    assert (row["lag_samples"], row["lag_source"]) == (delay, "xcorr")
    assert _values(row) == pytest.approx(_values(want), abs=0, nan_ok=False)
    (row,) = score_files([early], early_ref, dnsmos=dnsmos)
    assert (row["lag_samples"], row["lag_source"]) == (-delay, "xcorr")
    assert _values(row) == pytest.approx(_values(want), abs=0)
    (raw,) = score_files([late], ref, align=False, trim=True, dnsmos=False)
    assert raw["lag_source"] == "none" and raw["si_sdr_db"] < want["si_sdr_db"] - 1


def test_declared_delay_is_used_and_another_rate_falls_back(tmp_path, speech):
    """A file whose record declares its delay is aligned by it (lag_source declared), with no
    search; a record made at another rate declares nothing (cross-correlation)."""
    s, noisy = speech
    want = score(noisy, FS, reference=s, dnsmos=False)
    record = enhance_comment(enhancer="toy@1", params={}, latency_samples=123, removed=False, fs=FS,
                             scenesim_version="test")
    late = _wav(tmp_path / "late.wav", np.concatenate([np.zeros(123), noisy]), comment=record)
    ref = _wav(tmp_path / "ref.wav", s)
    assert declared_delay(late, FS) == 123 and declared_delay(late, 8000) is None
    (row,) = score_files([late], ref, dnsmos=False, max_lag_s=0.001)  # a search this narrow cannot find 123
    assert (row["lag_samples"], row["lag_source"]) == (123, "declared")
    assert _values(row) == pytest.approx(_values(want), abs=0)
    other = enhance_comment(enhancer="toy@1", params={}, latency_samples=123, removed=False, fs=8000,
                            scenesim_version="test")
    late8 = _wav(tmp_path / "late8.wav", np.concatenate([np.zeros(123), noisy]), comment=other)
    (row,) = score_files([late8], ref, dnsmos=False)
    assert (row["lag_samples"], row["lag_source"]) == (123, "xcorr")


def test_length_rule_allows_what_the_lag_explains_only(speech):
    s, noisy = speech
    assert align_pair(np.concatenate([np.zeros(50), noisy]), s, fs=FS).lag == 50  # tail kept: n + 50
    assert align_pair(np.concatenate([np.zeros(50), noisy])[: s.size], s, fs=FS).lag == 50  # cut: n
    with pytest.raises(Exception, match="differ by more than the lag explains; pass --trim"):
        align_pair(noisy[:-100], s, fs=FS)
    assert align_pair(noisy[:-100], s, fs=FS, trim=True).degraded.size == s.size - 100


def test_enhance_then_score_on_a_delayed_system_gets_the_aligned_values(tmp_path, speech, capsys):
    """Issue 32's done-when, with ss (latency 255 samples): enhance's default output is the input's
    length, records delay 0 and scores as the API's output advanced by 255; --keep-latency's output
    is aligned by its declared 255 and scores as that output cut to the overlap (equal to 1e-12:
    the same float32 samples); without alignment the delayed file scores far lower."""
    s, noisy = speech
    noisy_wav, ref = _wav(tmp_path / "noisy.wav", noisy), _wav(tmp_path / "clean.wav", s)
    out, kept = tmp_path / "ss.wav", tmp_path / "ss_kept.wav"
    assert main(["enhance", str(noisy_wav), str(out), "-e", "ss"]) == 0
    assert main(["enhance", str(noisy_wav), str(kept), "-e", "ss", "--keep-latency"]) == 0
    y, _ = sf.read(out, always_2d=True)
    y_kept, _ = sf.read(kept, always_2d=True)
    assert y.shape[0] == y_kept.shape[0] == s.size
    np.testing.assert_allclose(y[: s.size - 255, 0], y_kept[255:, 0], rtol=0, atol=0)
    api = make("ss").process(noisy[None], FS).output[0]
    np.testing.assert_allclose(y[: s.size - 255, 0], api[255:], rtol=0, atol=1e-6)  # float32 storage
    assert read_enhance_record(out)["delay_samples"] == 0 and read_enhance_record(kept)["delay_samples"] == 255
    capsys.readouterr()
    csv_out = tmp_path / "scores.csv"
    assert main(["score", str(out), str(kept), "--ref", str(ref), "--out", str(csv_out), "--no-dnsmos"]) == 0
    rows = {r["system"]: r for r in _csv(csv_out.read_text())}
    assert (rows["ss"]["lag_samples"], rows["ss"]["lag_source"]) == ("0", "declared")
    assert (rows["ss_kept"]["lag_samples"], rows["ss_kept"]["lag_source"]) == ("255", "declared")
    want = score(y[:, 0], FS, reference=s, dnsmos=False)
    want_kept = score(y_kept[255:, 0], FS, reference=s[: s.size - 255], dnsmos=False)
    for key in ("pesq_wb_mos_lqo", "stoi", "estoi", "si_sdr_db", "segsnr_db", "srmr"):
        assert float(rows["ss"][key]) == pytest.approx(want[key], rel=1e-12, abs=1e-12), key
        assert float(rows["ss_kept"][key]) == pytest.approx(want_kept[key], rel=1e-12, abs=1e-12), key
    (raw,) = score_files([kept], ref, align=False, dnsmos=False)
    assert raw["si_sdr_db"] < want_kept["si_sdr_db"] - 10 and raw["stoi"] < want_kept["stoi"] - 0.1


def test_long_records_drop_the_parameters_to_stay_readable(tmp_path):
    """libsndfile drops a WAV comment over 2040 characters silently: the record shortens itself."""
    text = enhance_comment(enhancer="x@1", params={"p": "v" * 3000}, latency_samples=9, removed=False,
                           fs=FS, scenesim_version="t")
    assert len(text) <= COMMENT_LIMIT
    path = _wav(tmp_path / "x.wav", np.zeros(100), comment=text)
    record = read_enhance_record(path)
    assert record["params_omitted"] is True and record["delay_samples"] == 9


@pytest.mark.parametrize("rate", [0, 1, 100_000_000])
def test_enhance_refuses_a_nonsense_header_rate_before_the_work(tmp_path, capsys, rate):
    src = wav_with_rate(tmp_path / "in.wav", rate, channels=2)
    out = tmp_path / "out.wav"
    assert main(["enhance", str(src), str(out), "-e", "passthrough"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scenesim: error:") and "\n" not in err
    assert f"{src} says its sample rate is {rate} Hz" in err and "[8000, 192000]" in err
    assert not out.exists()


@pytest.fixture
def toy_delay():
    """The toy whole-sample delay (tests/_toy_enhancers.py) registered for one test."""
    from enhancers.core.registry import register, unregister

    register("toy-delay", "_toy_enhancers:Delay")
    yield "toy-delay"
    unregister("toy-delay")


def test_compensated_toy_delay_returns_the_input_and_scores_as_it(tmp_path, speech, toy_delay):
    """Toy check (closed form): a pure delay of d samples with its latency removed is the input
    itself, sample for sample (float64 in, float32 out: equal to float32 rounding, 2^-24 relative);
    with --keep-latency it is the input delayed by d, and score aligns it by its declared d."""
    s, noisy = speech
    src, ref = _wav(tmp_path / "in.wav", noisy), _wav(tmp_path / "ref.wav", s)
    out, kept = tmp_path / "out.wav", tmp_path / "kept.wav"
    assert main(["enhance", str(src), str(out), "-e", toy_delay, "-p", "delay=40"]) == 0
    assert main(["enhance", str(src), str(kept), "-e", toy_delay, "-p", "delay=40", "--keep-latency"]) == 0
    y, _ = sf.read(out)
    y_kept, _ = sf.read(kept)
    np.testing.assert_allclose(y, noisy, rtol=2**-24, atol=0)
    np.testing.assert_allclose(y_kept[40:], noisy[:-40], rtol=2**-24, atol=0)
    assert np.all(y_kept[:40] == 0)
    rows = score_files([out, kept], ref, dnsmos=False)
    assert [(r["lag_samples"], r["lag_source"]) for r in rows] == [(0, "declared"), (40, "declared")]
    assert read_enhance_record(kept)["enhancer"] == "toy-delay@1" and read_enhance_record(kept)["params"] == {"delay": 40}
