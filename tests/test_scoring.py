"""The public metrics API (benchmarks.metrics.scoring) and ``scenesim score`` end to end on generated WAV files."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main
from benchmarks.metrics import speech as M
from benchmarks.metrics.scoring import (
    INTRUSIVE,
    NON_INTRUSIVE,
    pesq_wb_raw_from_mos_lqo,
    score,
    score_files,
)
from benchmarks.metrics.srmr import srmr

FS = 16000


def _speechlike(rng, seconds=3.0):
    """Seeded wide-band noise with a 3 Hz syllabic envelope (speech-like enough for PESQ/STOI)."""
    t = np.arange(int(seconds * FS)) / FS
    return 0.1 * rng.standard_normal(t.size) * (1 + np.sin(2 * np.pi * 3 * t)) ** 2


@pytest.fixture
def pair(rng):
    clean = _speechlike(rng)
    noisy = clean + 0.02 * rng.standard_normal(clean.size)
    return clean, noisy


def test_score_matches_the_metric_functions_it_reuses(pair):
    """Oracle: the functions of benchmarks.metrics.speech and benchmarks.metrics.srmr called directly (exact equality)."""
    clean, noisy = pair
    row = score(noisy, FS, reference=clean, dnsmos=False)
    p = M.pesq_scores(clean, noisy, fs=FS)
    st = M.stoi_scores(clean, noisy, fs=FS)
    assert row["pesq_nb_mos_lqo"] == p["nb"] and row["pesq_wb_mos_lqo"] == p["wb"]
    assert row["pesq_nb_raw"] == M.pesq_raw_from_mos_lqo(p["nb"])
    assert row["stoi"] == st["stoi"] and row["estoi"] == st["estoi"]
    assert row["si_sdr_db"] == M.si_sdr_db(clean, noisy)
    assert row["segsnr_db"] == M.segmental_snr_db(clean, noisy, fs=FS)
    assert row["srmr"] == srmr(noisy, FS)
    assert row["dnsmos_sig"] is None and row["error"] == ""


def test_score_without_reference_has_only_non_intrusive_columns(pair):
    row = score(pair[1], FS, dnsmos=False)
    assert all(row[k] is None for k in INTRUSIVE)
    assert row["srmr"] is not None


def test_wide_band_raw_inverts_the_p8622_mapping():
    """Closed form: P.862.2 maps raw x to 0.999 + 4 / (1 + exp(-1.3669 x + 3.8224)); inverted to 1e-9."""
    for x in (-0.4, 0.5, 2.0, 3.7, 4.4):
        y = 0.999 + 4 / (1 + math.exp(-1.3669 * x + 3.8224))
        assert abs(pesq_wb_raw_from_mos_lqo(y) - x) < 1e-9
    assert pesq_wb_raw_from_mos_lqo(4.7) == 4.5 and pesq_wb_raw_from_mos_lqo(1.0) == -0.5  # beyond the ends


def test_undefined_metric_is_empty_with_its_reason(rng):
    """A 0.2 s clip: PESQ needs 0.25 s, SRMR a 256 ms frame -> None with reasons; SI-SDR still defined."""
    clean = _speechlike(rng, 0.2)
    row = score(clean + 0.01, FS, reference=clean, dnsmos=False)
    assert row["pesq_nb_mos_lqo"] is None and row["srmr"] is None
    assert "PESQ needs at least 0.25 s" in row["error"] and "srmr:" in row["error"]
    assert row["si_sdr_db"] is not None


def _write(path, x, fs=FS):
    sf.write(path, np.asarray(x).T if np.ndim(x) == 2 else x, fs, subtype="DOUBLE")
    return path


def _csv(text):
    return list(csv.DictReader(io.StringIO(text)))


def test_cli_scores_folders_paired_by_name(tmp_path, rng, capsys):
    """Two files in DEG and REF folders: one row each, in name order, equal to score() on the arrays."""
    (tmp_path / "deg").mkdir()
    (tmp_path / "ref").mkdir()
    arrays = {}
    for name in ("b.wav", "a.wav"):
        clean = _speechlike(rng)
        noisy = clean + 0.03 * rng.standard_normal(clean.size)
        _write(tmp_path / "ref" / name, clean)
        _write(tmp_path / "deg" / name, noisy)
        arrays[name] = (clean, noisy)
    out = tmp_path / "scores.csv"
    assert main(["score", str(tmp_path / "deg"), "--ref", str(tmp_path / "ref"), "--out", str(out),
                 "--no-dnsmos"]) == 0
    rows = _csv(out.read_text())
    assert [r["file"].rsplit("/", 1)[-1] for r in rows] == ["a.wav", "b.wav"]
    assert set(INTRUSIVE) | set(NON_INTRUSIVE) <= set(rows[0])
    for r in rows:
        clean, noisy = arrays[r["file"].rsplit("/", 1)[-1]]
        expected = score(noisy, FS, reference=clean, dnsmos=False)
        assert r["reference"].endswith(r["file"].rsplit("/", 1)[-1])
        for key in ("pesq_nb_mos_lqo", "pesq_wb_raw", "stoi", "estoi", "si_sdr_db", "segsnr_db", "srmr"):
            assert float(r[key]) == pytest.approx(expected[key], rel=1e-12), key
        assert r["dnsmos_ovrl"] == ""


def test_cli_without_reference_prints_csv(tmp_path, rng, capsys):
    path = _write(tmp_path / "rec.wav", _speechlike(rng))
    assert main(["score", str(path), "--no-dnsmos"]) == 0
    rows = _csv(capsys.readouterr().out)
    assert len(rows) == 1 and rows[0]["pesq_nb_mos_lqo"] == "" and float(rows[0]["srmr"]) > 0
    assert float(rows[0]["duration_s"]) == 3.0 and rows[0]["fs"] == "16000"


@pytest.mark.parametrize(
    "make_ref, message",
    [
        (lambda c: (c, 8000), "is 16000 Hz but its reference"),
        (lambda c: (c[:-160], FS), "pass --trim"),
    ],
    ids=["rate", "length"],
)
def test_cli_mismatched_pair_fails_its_row_with_the_fix(tmp_path, rng, capsys, make_ref, message):
    """A pair that cannot be scored is a failed row with the reason; the exit status is 1."""
    clean = _speechlike(rng)
    deg = _write(tmp_path / "deg.wav", clean + 0.01)
    ref_x, ref_fs = make_ref(clean)
    ref = _write(tmp_path / "ref.wav", ref_x, ref_fs)
    assert main(["score", str(deg), "--ref", str(ref), "--no-dnsmos", "--no-align"]) == 1
    captured = capsys.readouterr()
    (row,) = _csv(captured.out)
    assert row["status"] == "failed" and message in row["error"] and row["stoi"] == ""
    assert "1 file(s): 0 scored, 1 failed" in captured.err


def test_cli_multichannel_without_channel_is_one_line_with_the_fix(tmp_path, rng, capsys):
    clean = _speechlike(rng)
    deg = _write(tmp_path / "deg.wav", clean + 0.01)
    ref = _write(tmp_path / "ref.wav", np.stack([clean, clean]))
    assert main(["score", str(deg), "--ref", str(ref), "--no-dnsmos"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scenesim: error:") and "pass --channel I" in err and "\n" not in err


def test_trim_and_channel_options_fix_the_mismatches(tmp_path, rng):
    clean = _speechlike(rng)
    deg = _write(tmp_path / "deg.wav", np.stack([clean + 0.01, clean]))
    ref = _write(tmp_path / "ref.wav", np.stack([clean[:-160], clean[:-160]]))
    row = score_files([deg], ref, channel=1, trim=True, dnsmos=False)[0]
    assert row["si_sdr_db"] > 100  # channel 1 is the clean signal itself, trimmed to the reference
    assert row["duration_s"] == (clean.size - 160) / FS


def test_missing_reference_in_folder_fails_that_row_and_names_it(tmp_path, rng, capsys):
    (tmp_path / "deg").mkdir()
    (tmp_path / "ref").mkdir()
    _write(tmp_path / "deg" / "x.wav", _speechlike(rng))
    _write(tmp_path / "deg" / "y.wav", _speechlike(rng))
    _write(tmp_path / "ref" / "y.wav", _speechlike(rng))
    assert main(["score", str(tmp_path / "deg"), "--ref", str(tmp_path / "ref"), "--no-dnsmos"]) == 1
    rows = {r["utterance"]: r for r in _csv(capsys.readouterr().out)}
    assert rows["x"]["status"] == "failed" and "no reference x.wav/.flac under" in rows["x"]["error"]
    assert rows["y"]["status"] == "ok"


def test_scoring_at_48_khz_matches_the_same_speech_scored_at_16_khz():
    # Oracle: a signal band-limited below 4.1 kHz (far from either Nyquist) holds the same content at 48 and 16 kHz, so every
    # score resampled to 16 kHz (PESQ, STOI, SRMR) agrees within 0.05 / 0.01 / 0.05, and SI-SDR
    # (rate free) within 0.1 dB.  A wrong resampling ratio moves them by far more.
    from scenesim.audio import resample

    rng = np.random.default_rng(3)
    t = np.arange(3 * 16000) / 16000
    clean16 = 0.1 * np.clip(np.sin(2 * np.pi * 3 * t), 0, None) * sum(
        np.sin(2 * np.pi * 140 * k * t) / k for k in range(1, 30))
    deg16 = clean16 + 0.01 * resample(rng.standard_normal((1, t.size // 2)), 8000, 16000)[0]  # below 4 kHz
    clean48, deg48 = (resample(x[None], 16000, 48000)[0] for x in (clean16, deg16))
    a = score(deg16, 16000, reference=clean16, dnsmos=False)
    b = score(deg48, 48000, reference=clean48, dnsmos=False)
    for key, tol in (("pesq_wb_mos_lqo", 0.05), ("pesq_nb_mos_lqo", 0.05), ("stoi", 0.01),
                     ("srmr", 0.05), ("si_sdr_db", 0.1)):
        assert b[key] == pytest.approx(a[key], abs=tol), key
