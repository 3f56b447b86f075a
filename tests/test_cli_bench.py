"""End to end through the CLI: ``scenesim bench run smoke``, ``bench report``, ``bench list``."""

from __future__ import annotations

import sqlite3

import pytest
from _bench_smoke import local_smoke_run

from benchmarks.cli.main import main
from benchmarks.run.sweep import load_sweep


def _rows(out):
    db = sqlite3.connect(out / "results.sqlite")
    db.row_factory = sqlite3.Row
    try:
        return [dict(r) for r in db.execute("SELECT * FROM results")]
    finally:
        db.close()


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    """``scenesim bench run smoke`` into a fresh directory (one worker: no pool start-up)."""
    return local_smoke_run(tmp_path_factory)


def test_smoke_end_to_end_rows_and_report(smoke_run, capsys):
    code, out = smoke_run
    assert code == 0
    sweep = load_sweep("smoke")
    rows = _rows(out)
    assert len(rows) == len(sweep.conditions()) * len(sweep.enhancers) == 16
    assert {r["status"] for r in rows} == {"ok"}, [r["error"] for r in rows if r["status"] != "ok"]
    assert {r["enhancer"] for r in rows} == {"eb", "ss", "eb-ss", "passthrough"}
    assert len({(r["condition_id"], r["enhancer"]) for r in rows}) == 16
    for r in rows:
        for col in ("snr_out_db", "snr_i_db", "pesq_nb_in", "pesq_nb_out", "pesq_wb_in", "pesq_wb_out", "stoi_in", "stoi_out"):
            assert r[col] is not None, (col, r["enhancer"], r["error"])
        assert r["speech_source"] == "artificial-voice" and r["noise_source"].startswith("synthetic:")
    # passthrough is the reference mic: its SNR-I is 0 by construction (shadow filtering of the
    # identity), to rounding.
    for r in rows:
        if r["enhancer"] == "passthrough":
            assert r["snr_i_db"] == pytest.approx(0.0, abs=1e-9)
    report = out / "report"
    assert (report / "summary.md").is_file()
    assert list(report.glob("*.csv")) and list(report.glob("*.png"))
    assert "smoke" in (report / "summary.md").read_text()


def test_rerun_computes_nothing(smoke_run, capsys):
    _, out = smoke_run
    before = {(r["condition_id"], r["enhancer"]): r["created_at"] for r in _rows(out)}
    assert main(["bench", "run", "smoke", "--out", str(out), "--workers", "1", "--no-report"]) == 0
    err = capsys.readouterr().err
    assert "0 computed, 4 already stored" in err
    assert {(r["condition_id"], r["enhancer"]): r["created_at"] for r in _rows(out)} == before


def test_bench_report_rewrites_the_report(smoke_run, capsys):
    _, out = smoke_run
    summary = out / "report" / "summary.md"
    summary.unlink()
    assert main(["bench", "report", str(out)]) == 0
    assert summary.is_file()
    assert str(summary) in capsys.readouterr().out


def test_bench_report_on_a_directory_without_store(tmp_path, capsys):
    assert main(["bench", "report", str(tmp_path)]) == 2
    assert "no results store" in capsys.readouterr().err


def test_bench_list_shows_presets_enhancers_and_noises(capsys):
    assert main(["bench", "list"]) == 0
    out = capsys.readouterr().out
    for name, n in (("thesis", 18), ("reverb", 80), ("distance", 36), ("angles", 24), ("smoke", 4)):
        assert name in out and f"{n:4d} conditions" in out
    for name in ("eb", "ss", "eb-ss", "passthrough"):
        assert f"\n  {name} " in out
    assert "scenesim" in out  # source package of the built-ins
    for noise in ("babble", "factory", "wind"):
        assert f"  {noise}\n" in out


def test_bad_sweep_file_is_one_clear_error_with_key_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[axes]\nenhancers = ["eb"]\nnoise = ["babble"]\nsnr_db = [0]\n\n[fixed]\nduraton_s = 2\n')
    assert main(["bench", "run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "line 7" in err and "fixed.duraton_s" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_scheduler_without_dask_is_refused(tmp_path, capsys):
    assert main(["bench", "run", "smoke", "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "--scheduler" in capsys.readouterr().err


def test_thesis_babble_0db_ordering_on_real_data(shared_data_dir, tmp_path):
    """The thesis' headline (tables 7.1, 7.4, 7.7, babble at 0 dB): SNR-I of EB-SS > EB > SS.

    ``--limit 1`` runs the first thesis condition, babble at 0 dB, on the real speech and noise."""
    out = tmp_path / "thesis"
    code = main(["bench", "run", "thesis", "--out", str(out), "--limit", "1", "--workers", "1",
                 "--data-dir", str(shared_data_dir), "--no-report"])  # fmt: skip
    assert code == 0
    rows = {r["enhancer"]: r for r in _rows(out)}
    assert set(rows) == {"eb", "ss", "eb-ss", "passthrough"}
    assert all(r["noise"] == "babble" and r["snr_in_db"] == 0 and r["status"] == "ok" for r in rows.values())
    assert rows["eb"]["speech_source"].startswith("local:")
    snr_i = {k: r["snr_i_db"] for k, r in rows.items()}
    assert snr_i["eb-ss"] > snr_i["eb"] > snr_i["ss"] > 0, snr_i


def test_seed_offset_is_applied_once(tmp_path):
    """``--seed S`` offsets the sweep's seeds by S once (it used to be applied by the CLI and again
    by ``run_sweep``: seed 0 became 2 S), with and without ``--seeds N``."""
    sweep = tmp_path / "s.toml"
    sweep.write_text('[axes]\nenhancers = ["passthrough"]\nnoise = ["white"]\nsnr_db = [10]\n'
                     '[fixed]\nduration_s = 1.0\nmetrics = []\n', "utf-8")
    for extra, expected in (([], {3}), (["--seeds", "2"], {3, 4})):
        out = tmp_path / f"o{len(extra)}"
        args = ["bench", "run", str(sweep), "--out", str(out), "--workers", "1", "--no-report", "--seed", "3"]
        assert main([*args, *extra]) == 0
        assert {r["seed"] for r in _rows(out)} == expected
