"""Issue 32 part 2 and issue 33 (classes 1, 2, 3, 7, 8) for ``scenesim score``: an evaluation.

Known answers are built from SI-SDR's closed form: with a zero-mean reference ``s`` and an error
``e`` zero-mean and orthogonal to ``s``, SI-SDR(s, s + e) = 10 log10(|s|^2 / |e|^2) exactly
(Le Roux et al. 2019, eq. 3-4 with alpha = 1), so each file's SI-SDR is chosen, and the summary
and paired intervals follow from Student's t (scipy.stats as the outside implementation).
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
import soundfile as sf
from _wav_headers import wav_with_rate
from scipy import stats

from benchmarks.cli.main import main
from benchmarks.cli.score_eval import output_paths
from benchmarks.metrics.scoring import score_files

FS = 16000
SISDR = {"A": (5.0, 7.0, 9.0, 11.0), "B": (6.0, 9.0, 10.0, 13.0), "C": (1.0, 2.0, 4.0)}  # C lacks u4


def _speechlike(rng, seconds=1.0):
    t = np.arange(int(seconds * FS)) / FS
    x = 0.1 * rng.standard_normal(t.size) * (1 + np.sin(2 * np.pi * 3 * t)) ** 2
    return x - x.mean()


def _at_sisdr(s, snr_db, rng):
    """``s + e`` with e zero-mean, orthogonal to s and |s|^2 / |e|^2 = 10^(snr/10)."""
    e = rng.standard_normal(s.size)
    e -= e.mean()
    e -= (e @ s) / (s @ s) * s
    e -= e.mean()
    return s + e * np.sqrt((s @ s) / (e @ e) / 10 ** (snr_db / 10))


def _write(path, x, fs=FS):
    path.parent.mkdir(parents=True, exist_ok=True)
    sf.write(path, np.asarray(x).T, fs, subtype="DOUBLE")
    return path


@pytest.fixture
def evaluation(tmp_path, rng):
    """ref/spk/u1..u4.wav; systems A/spk, B/spk (four utterances) and C/spk (three)."""
    refs = {f"u{i}": _speechlike(rng) for i in range(1, 5)}
    for u, s in refs.items():
        _write(tmp_path / "ref" / "spk" / f"{u}.wav", s)
    for system, values in SISDR.items():
        for u, v in zip(refs, values):
            _write(tmp_path / system / "spk" / f"{u}.wav", _at_sisdr(refs[u], v, rng))
    return tmp_path


def _csv(path):
    return list(csv.DictReader(io.StringIO(path.read_text())))


def _run(root, *extra):
    return main(["score", str(root / "A"), str(root / "B"), str(root / "C"), "--ref", str(root / "ref"),
                 "--no-dnsmos", "--no-align", *extra])


def test_rows_summary_and_paired_comparisons_have_the_known_answers(evaluation, capsys):
    """Per-file SI-SDR equals the constructed value to 1e-9 dB; the summary's mean, median and
    t-interval and the paired B - A interval equal scipy.stats' on those values (1e-9)."""
    out = evaluation / "res" / "scores.csv"
    assert _run(evaluation, "--out", str(out)) == 0
    assert "11 file(s): 11 scored, 0 failed -> " in capsys.readouterr().out
    rows = _csv(out)
    assert [(r["system"], r["utterance"]) for r in rows][:5] == [("A", f"spk/u{i}") for i in range(1, 5)] + [("B", "spk/u1")]
    for r in rows:
        assert float(r["si_sdr_db"]) == pytest.approx(SISDR[r["system"]][int(r["utterance"][-1]) - 1], abs=1e-9)
    paths = output_paths(out)
    summary = {(r["system"], r["metric"]): r for r in _csv(paths["summary"])}
    for system, values in SISDR.items():
        rec = summary[(system, "si_sdr_db")]
        lo, hi = stats.t.interval(0.95, len(values) - 1, loc=np.mean(values), scale=stats.sem(values))
        assert int(rec["n"]) == len(values)
        assert [float(rec[k]) for k in ("mean", "median", "ci_low", "ci_high")] == pytest.approx(
            [np.mean(values), np.median(values), lo, hi], abs=1e-9)
    paired = {(r["system_a"], r["system_b"], r["metric"]): r for r in _csv(paths["paired"])}
    ab = paired[("A", "B", "si_sdr_db")]
    ci = stats.ttest_rel(SISDR["B"], SISDR["A"]).confidence_interval(0.95)
    assert int(ab["n"]) == 4 and float(ab["mean_diff"]) == pytest.approx(1.5, abs=1e-9)
    assert [float(ab["ci_low"]), float(ab["ci_high"])] == pytest.approx([ci.low, ci.high], abs=1e-9)
    ac = paired[("A", "C", "si_sdr_db")]  # over the three common utterances only
    assert int(ac["n"]) == 3 and float(ac["mean_diff"]) == pytest.approx(np.mean([-4.0, -5.0, -5.0]), abs=1e-9)


def test_versions_sidecar_names_the_metric_packages(evaluation):
    out = evaluation / "scores.csv"
    assert _run(evaluation, "--out", str(out)) == 0
    record = json.loads(output_paths(out)["versions"].read_text())
    from importlib import metadata

    assert record["versions"]["pesq"] == metadata.version("pesq")
    assert record["versions"]["pystoi"] == metadata.version("pystoi")
    assert record["versions"]["scenesim"] and record["files"] == {"scored": 11, "failed": 0}
    assert record["options"]["align"] is False


def test_dnsmos_columns_and_model_digests_when_installed(tmp_path, rng):
    pytest.importorskip("speechmos", reason="optional extra not installed: pip install -e '.[dnsmos]'")
    s = _speechlike(rng)
    deg = _write(tmp_path / "sys" / "u.wav", 0.2 * _at_sisdr(s, 10.0, rng))  # within full scale
    out = tmp_path / "s.csv"
    assert main(["score", str(deg), "--dnsmos", "--out", str(out)]) == 0
    (row,) = _csv(out)
    assert 1.0 < float(row["dnsmos_p808"]) < 5.0 and 1.0 < float(row["dnsmos_ovrl"]) < 5.0, row["error"]
    digests = json.loads(output_paths(out)["versions"].read_text())["versions"]["dnsmos_models_sha256"]
    assert set(digests) == {"sig_bak_ovr.onnx", "model_v8.onnx"} and all(len(d) == 64 for d in digests.values())


def test_two_workers_equal_serial(evaluation):
    serial = score_files([evaluation / "A", evaluation / "B"], evaluation / "ref", dnsmos=False)
    pooled = score_files([evaluation / "A", evaluation / "B"], evaluation / "ref", dnsmos=False, workers=2)
    assert pooled == serial and len(serial) == 8


def test_pairs_list_and_one_reference_for_many(evaluation, rng):
    """A pairs list gives the folders' rows (systems named in the list); one --ref file scores
    several outputs, each its own system."""
    lines = ["ref,deg,system"] + [f"ref/spk/u{i}.wav,{s}/spk/u{i}.wav,{s}" for s in "AB" for i in range(1, 5)]
    (evaluation / "pairs.csv").write_text("\n".join(lines) + "\n")
    listed = score_files(pairs=evaluation / "pairs.csv", dnsmos=False, align=False)
    folders = score_files([evaluation / "A", evaluation / "B"], evaluation / "ref", dnsmos=False, align=False)
    assert [(r["system"], r["si_sdr_db"]) for r in listed] == [(r["system"], r["si_sdr_db"]) for r in folders]
    one = score_files([evaluation / "A" / "spk" / "u1.wav", evaluation / "B" / "spk" / "u1.wav"],
                      evaluation / "ref" / "spk" / "u1.wav", dnsmos=False, align=False)
    assert [(r["system"], r["utterance"]) for r in one] == [("A/spk/u1", "u1"), ("B/spk/u1", "u1")]
    assert [r["si_sdr_db"] for r in one] == pytest.approx([SISDR["A"][0], SISDR["B"][0]], abs=1e-9)


def test_a_failing_file_fails_its_row_and_the_batch_goes_on(evaluation, capsys):
    """Unreadable, too long for the trim rule: empty metrics with the reason; others scored; exit 1."""
    (evaluation / "A" / "spk" / "u2.wav").write_bytes(b"RIFF....not audio")
    _write(evaluation / "A" / "spk" / "u3.wav", np.zeros(FS + 500) + 0.01)
    out = evaluation / "scores.csv"
    assert _run(evaluation, "--out", str(out)) == 1
    assert "11 file(s): 9 scored, 2 failed (see their error column)" in capsys.readouterr().out
    rows = {(r["system"], r["utterance"]): r for r in _csv(out)}
    assert "cannot read audio file" in rows[("A", "spk/u2")]["error"] and rows[("A", "spk/u2")]["stoi"] == ""
    assert "pass --trim" in rows[("A", "spk/u3")]["error"] and rows[("A", "spk/u3")]["status"] == "failed"
    assert rows[("A", "spk/u1")]["status"] == "ok" and rows[("B", "spk/u3")]["status"] == "ok"
    assert json.loads(output_paths(out)["versions"].read_text())["files"] == {"scored": 9, "failed": 2}


def test_degenerate_scores_are_empty_with_the_reason(tmp_path, rng):
    """Issue 33 class 7: an all-zero output is not SI-SDR 0 dB; a silent reference not -324.7 dB."""
    s = _speechlike(rng)
    ref, silent_ref = _write(tmp_path / "r.wav", s), _write(tmp_path / "z.wav", np.zeros(s.size))
    zero = _write(tmp_path / "zero.wav", np.zeros(s.size))
    (row,) = score_files([zero], ref, dnsmos=False)
    assert row["si_sdr_db"] is None and row["segsnr_db"] is None and "silent output" in row["error"]
    (row,) = score_files([_write(tmp_path / "d.wav", s)], silent_ref, dnsmos=False)
    assert row["si_sdr_db"] is None and row["stoi"] is None and "silent reference" in row["error"]
    assert row["status"] == "ok" and row["srmr"] is not None  # the non-intrusive scores stand


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("scenesim: error:") and "\n" not in err, err
    return err


@pytest.mark.parametrize("rate", [0, 1, 100_000_000])
@pytest.mark.parametrize("role", ["deg", "ref"])
def test_nonsense_header_rate_is_refused_before_any_work(tmp_path, rng, capsys, rate, role):
    good = _write(tmp_path / "good.wav", _speechlike(rng))
    bad = wav_with_rate(tmp_path / "bad.wav", rate)
    args = [str(bad), "--ref", str(good)] if role == "deg" else [str(good), "--ref", str(bad)]
    out = tmp_path / "s.csv"
    assert main(["score", *args, "--no-dnsmos", "--out", str(out)]) == 2
    assert f"{bad} says its sample rate is {rate} Hz" in _one_line(capsys)
    assert not out.exists()


def test_out_that_is_an_input_is_refused_and_the_input_kept(evaluation, capsys):
    """Issue 33 class 2: score ... --out A/spk/u1.wav overwrote the recording with CSV text."""
    target = evaluation / "A" / "spk" / "u1.wav"
    before = target.read_bytes()
    assert _run(evaluation, "--out", str(target)) == 2
    assert f"--out={str(target)!r}" in _one_line(capsys)
    assert target.read_bytes() == before
    listing = evaluation / "pairs.csv"  # an input that is not audio: the list of pairs itself
    listing.write_text("ref/spk/u1.wav,A/spk/u1.wav\n")
    assert main(["score", "--pairs", str(listing), "--out", str(listing), "--no-dnsmos"]) == 2
    assert f"--out={str(listing)!r} is invalid: expected a file that is not one of the inputs" in _one_line(capsys)
    assert listing.read_text() == "ref/spk/u1.wav,A/spk/u1.wav\n"


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["--channel", "2"], ["--channel=2", "a channel index in 0..0", "is mono"]),
        (["--channel", "-1"], ["--channel=-1", "a channel index >= 0"]),
        (["--max-lag-ms", "0"], ["--max-lag-ms=0.0", "(0, 10000] ms"]),
        (["--workers", "0"], ["--workers=0", "[1, 64]"]),
        (["--out", "x.wav"], ["--out='x.wav'", "a CSV file name"]),
        (["--pairs", "p.csv"], ["--pairs='p.csv'", "drop DEG and --ref"]),
    ],
    ids=["channel-mono", "channel-negative", "max-lag", "workers", "out-audio", "pairs-and-deg"],
)
def test_bad_options_are_one_line_naming_what_was_typed(evaluation, capsys, monkeypatch, argv, needles):
    monkeypatch.chdir(evaluation)
    assert _run(evaluation, *argv) == 2
    err = _one_line(capsys)
    assert all(n in err for n in needles), err


def test_malformed_pairs_list_and_twin_folders_are_one_line(evaluation, capsys, tmp_path):
    bad = evaluation / "pairs.csv"
    bad.write_text("ref/spk/u1.wav\n")
    assert main(["score", "--pairs", str(bad), "--no-dnsmos"]) == 2
    assert f"{bad} line 1: expected ref,deg[,system]" in _one_line(capsys)
    twin = evaluation / "other" / "A"
    _write(twin / "u1.wav", np.zeros(10))
    assert main(["score", str(evaluation / "A"), str(twin), "--ref", str(evaluation / "ref"), "--no-dnsmos"]) == 2
    assert "are both named 'A'" in _one_line(capsys)


def test_requested_dnsmos_without_the_extra_is_one_line(evaluation, capsys, monkeypatch):
    from benchmarks.metrics import dnsmos

    monkeypatch.setattr(dnsmos, "installed", lambda: False)
    assert main(["score", str(evaluation / "A"), "--dnsmos"]) == 2
    assert 'DNSMOS needs the optional [dnsmos] extra: pip install "scenesim[dnsmos]"' in _one_line(capsys)
