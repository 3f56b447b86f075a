"""Issue 15 part 2, ``bench run``/``compare``/sweep files: a run whose rows all failed exits
non-zero (some failed: says how many); unreadable or misnamed sweep inputs and unknown
``--metrics`` give one line naming what was typed; plugin names that cannot work are refused."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.cli.main import main

SWEEP = """[axes]
enhancers = ["passthrough", "ss"]
noise = ["wind"]
snr_db = [5]
[fixed]
duration_s = 0.5
"""


def _run(tmp_path, capsys, monkeypatch=None, n_failed=0):
    """``bench run`` of a 2-row sweep; with ``n_failed``, the first rows of the run are stored as
    failed instead (a worker's crash cannot be forced from here: workers are separate processes)."""
    import dataclasses

    import benchmarks.run.runner as runner

    real = runner.run_sweep

    def failing(sweep, out, **kwargs):
        summary = real(sweep, out, **kwargs)
        from benchmarks.store.sqlite import ResultStore

        with ResultStore.open(out) as store:
            rows = store.rows("run_id = ?", (summary.run_id,))[:n_failed]
            store.write_rows([{**r, "status": "error", "error": "boom in the enhancer"} for r in rows])
        return dataclasses.replace(summary, n_errors=n_failed)

    if monkeypatch is not None:
        monkeypatch.setattr(runner, "run_sweep", failing)
    path = tmp_path / "s.toml"
    path.write_text(SWEEP, "utf-8")
    rc = main(["bench", "run", str(path), "--out", str(tmp_path / "out"), "--workers", "1", "--no-report"])
    return rc, capsys.readouterr().err


def test_a_run_whose_rows_all_failed_exits_non_zero_and_says_why(tmp_path, capsys, monkeypatch):
    rc, err = _run(tmp_path, capsys, monkeypatch, n_failed=2)
    assert rc == 1, err
    assert "scenesim: error: all 2 rows of this run failed" in err and "boom in the enhancer" in err, err


def test_a_partly_failed_run_says_how_many(tmp_path, capsys, monkeypatch):
    rc, err = _run(tmp_path, capsys, monkeypatch, n_failed=1)
    assert rc == 0, err
    assert "scenesim: warning: 1 of 2 rows of this run failed" in err, err


def test_a_clean_run_says_nothing_about_failures(tmp_path, capsys):
    rc, err = _run(tmp_path, capsys)
    assert rc == 0 and "failed" not in err, err


def test_non_utf8_sweep_file_is_one_line_naming_the_line(tmp_path, capsys):
    path = tmp_path / "latin1.toml"
    path.write_bytes('[axes]\nenhancers = ["eb"]\n# café\n'.encode("latin-1"))
    assert main(["bench", "run", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scenesim: error:") and "line 3" in err and "UTF-8" in err and "\n" not in err, err


def test_a_directory_passed_as_the_sweep_is_called_a_directory(tmp_path, capsys):
    assert main(["bench", "run", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "is a directory" in err and "unknown preset" not in err, err


@pytest.mark.parametrize("metric, needle", [("no_such_column", "not a column"), ("enhancer", "a text column")])
def test_compare_metrics_must_be_numeric_columns_of_a_real_store(metric, needle, tmp_path, capsys):
    rc, _ = _run(tmp_path, capsys)
    assert rc == 0
    store = str(tmp_path / "out")
    assert main(["bench", "compare", store, store, "--out", str(tmp_path / "c"), "--metrics", metric]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"scenesim: error: Parameter --metrics='{metric}'") and needle in err, err
    assert main(["bench", "compare", store, store, "--out", str(tmp_path / "c"), "--metrics", "snr_i_db"]) == 0


@pytest.mark.parametrize("name", ["none", "true", "tags", "enhancer", "params", "result"])
def test_plugin_names_that_would_not_import_are_refused(name, tmp_path, capsys):
    assert main(["plugin", "new", name, "--dest", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert f"NAME='{name}'" in err and "keyword" in err and not (tmp_path / "p").exists(), err


_FILL_UNDER_A_SIZE_LIMIT = """
import resource, signal, sqlite3, sys
from pathlib import Path
from benchmarks.cli.checks import corrupt_store_error
path = Path(sys.argv[1])
db = sqlite3.connect(path)
db.execute("CREATE TABLE results (x BLOB)")
db.execute("INSERT INTO results VALUES (x'00')")
db.commit()
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of a kill, as with a quota
resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, resource.RLIM_INFINITY))
try:
    for _ in range(100):
        db.execute("INSERT INTO results VALUES (?)", (b"x" * 10_000,))
        db.commit()
except sqlite3.DatabaseError as exc:
    print(corrupt_store_error(path, exc))
"""


def test_a_refused_write_is_not_called_corruption_and_the_store_stays_readable(tmp_path):
    import sqlite3
    import subprocess
    import sys

    path = tmp_path / "results.sqlite"
    proc = subprocess.run([sys.executable, "-c", _FILL_UNDER_A_SIZE_LIMIT, str(path)],
                          capture_output=True, text=True, check=True)
    message = proc.stdout.strip()
    assert message.startswith("could not write the results store") and "intact" in message, proc
    assert "corrupt" not in message and "mv " not in message and "Move it aside" not in message
    with sqlite3.connect(path) as db:  # the advice is right: the store is healthy
        assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert db.execute("SELECT COUNT(*) FROM results").fetchone()[0] >= 1


def test_a_damaged_store_is_still_called_corrupt(tmp_path):
    import sqlite3

    from benchmarks.cli.checks import corrupt_store_error

    path = tmp_path / "results.sqlite"
    path.write_bytes(b"not a database" * 500)
    with pytest.raises(sqlite3.DatabaseError) as info:
        sqlite3.connect(path).execute("SELECT * FROM sqlite_master").fetchall()
    assert "Move it aside" in str(corrupt_store_error(path, info.value))


def test_reordering_enhancers_is_the_same_version_and_another_sweep_is_named(tmp_path, capsys):
    rc, _ = _run(tmp_path, capsys)
    assert rc == 0
    out = str(tmp_path / "out")
    swapped = tmp_path / "s.toml"
    swapped.write_text(SWEEP.replace('["passthrough", "ss"]', '["ss", "passthrough"]'), "utf-8")
    assert main(["bench", "run", str(swapped), "--out", out, "--workers", "1", "--no-report"]) == 0
    assert "0 computed, 1 already stored" in capsys.readouterr().err
    other = tmp_path / "other.toml"
    other.write_text(SWEEP.replace("snr_db = [5]", "snr_db = [10]"), "utf-8")
    assert main(["bench", "run", str(other), "--out", out, "--workers", "1", "--no-report"]) == 2
    err = capsys.readouterr().err
    assert "of sweep 's', not 'other'" in err and "another version of sweep 'other'" not in err, err


def test_a_data_dir_that_is_a_file_is_called_a_file(tmp_path, capsys):
    a_file = tmp_path / "data"
    a_file.write_text("not a folder", "utf-8")
    assert main(["bench", "run", "smoke", "--out", str(tmp_path / "o"), "--data-dir", str(a_file)]) == 2
    err = capsys.readouterr().err
    assert "is a file, not a directory" in err and "does not exist" not in err, err


def test_a_killed_runs_row_is_marked_when_its_stale_lock_is_cleared(tmp_path, capsys):
    # What kill -9 leaves: a runs row 'running' and a lock file naming a dead pid (flock released).
    import json
    import sqlite3

    from benchmarks.run.lock import LOCK_NAME
    from benchmarks.store.sqlite import ResultStore

    out = tmp_path / "out"
    out.mkdir()
    with ResultStore.open(out) as store:
        dead = store.start_run(sweep="s", source="s.toml", config_toml=SWEEP, options={}, executor="local",
                               workers=1, scheduler=None, data_dir=None)
    (out / LOCK_NAME).write_text(json.dumps({"pid": 999999, "host": "h", "started": "t"}))
    rc, err = _run(tmp_path, capsys)
    assert rc == 0 and "marked 1 run(s)" in err and "'killed'" in err, err
    status = dict(sqlite3.connect(out / "results.sqlite").execute("SELECT run_id, status FROM runs").fetchall())
    assert status.pop(dead) == "killed" and list(status.values()) == ["finished"], status


def test_progress_says_a_block_is_computing_before_the_first_condition_finishes():
    import io

    from benchmarks.run.progress import LineProgress

    progress = LineProgress(6, "s", stream=io.StringIO())
    assert "the first block of conditions is computing" in progress.line()
    progress.update(6)
    assert "computing" not in progress.line() and progress.line().startswith("6/6 conditions (100 %)")


def test_load_results_on_a_real_sweeps_store(tmp_path, capsys):
    # Issue 15 part 5: hand-made stores lack the columns real sweeps write.  Oracle: the store
    # read row by row with sqlite; the frame keeps every column, its order and numeric types.
    import sqlite3

    pytest.importorskip("pandas")
    from benchmarks.store.frame import load_results
    from benchmarks.store.sqlite import COLUMNS

    rc, _ = _run(tmp_path, capsys)
    assert rc == 0
    out = tmp_path / "out"
    db = sqlite3.connect(out / "results.sqlite")
    names = [r[1] for r in db.execute("PRAGMA table_info(results)")]
    stored = db.execute("SELECT enhancer, snr_i_db, pesq_nb_out, condition_json FROM results ORDER BY rowid").fetchall()
    df = load_results(out, ok_only=True)
    assert set(df.columns) == set(names) and list(df.columns[:5]) == [c for c in COLUMNS if c in names][:5]
    assert list(df["enhancer"]) == [r[0] for r in stored] == ["passthrough", "ss"]
    np.testing.assert_allclose(df["snr_i_db"].to_numpy(dtype=float), [r[1] for r in stored], rtol=0, atol=0)
    assert df["snr_i_db"].iloc[0] == pytest.approx(0.0, abs=1e-9) and df["snr_i_db"].iloc[1] != 0.0
    assert df["pesq_nb_out"].dtype.kind == "f" and df["condition_json"].iloc[0] == stored[0][3]


def test_a_corrupt_store_is_one_line_from_compare_and_from_load_results(tmp_path, capsys):
    # Every way in to a store (the CLI's compare, the Python API) reports sqlite's "not a database" as the
    # store's one-line error, never a sqlite3 traceback.
    import benchmarks
    from benchmarks.cli.main import main
    from scenesim.errors import DataError

    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "results.sqlite").write_text("garbage, not sqlite")
    with pytest.raises(DataError, match=r"results.sqlite is corrupt or unreadable \(file is not a database\)"):
        benchmarks.load_results(bad)
    assert main(["bench", "compare", str(bad), str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("scenesim: error: the results store") and "\n" not in err and "Traceback" not in err


def test_report_listen_with_an_unknown_condition_id_is_refused(tmp_path, capsys):
    from benchmarks.cli.main import main
    from benchmarks.store.sqlite import ResultStore

    out = tmp_path / "s"
    with ResultStore.open(out) as store:
        store.write_rows([{"condition_id": "c1", "enhancer": "eb", "status": "ok"}])
    assert main(["bench", "report", str(out), "--listen", "nosuchid", "--listen-count", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--listen='nosuchid' is invalid" in err and "one of its 1, e.g. c1" in err and "\n" not in err
    assert not (out / "report").exists()


def test_compare_out_naming_an_existing_file_is_refused_in_one_line(tmp_path, capsys):
    from benchmarks.cli.main import main
    from benchmarks.store.sqlite import ResultStore

    out = tmp_path / "s"
    with ResultStore.open(out) as store:
        store.write_rows([{"condition_id": "c1", "enhancer": "eb", "status": "ok"}])
    afile = tmp_path / "afile"
    afile.write_text("keep me")
    assert main(["bench", "compare", str(out), str(out), "--out", str(afile)]) == 2
    err = capsys.readouterr().err.strip()
    assert f"--out='{afile}' is invalid: expected a directory, but it is an existing file" in err
    assert afile.read_text() == "keep me"


def test_a_sweep_needing_a_missing_extra_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    """One rule for optional extras: an enhancer behind one (peers' black boxes) or metrics = ["dnsmos"]
    without speechmos is a one-line error naming the extra's install line, before the store exists."""
    import importlib.util

    from benchmarks.cli.main import main
    from enhancers.core.registry import get_spec

    monkeypatch.setattr(get_spec("webrtc-ns"), "not_installed", "pip install -e '.[webrtc]'")
    assert main(["bench", "run", "peers", "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err.strip()
    assert "enhancer 'webrtc-ns' is not installed: pip install -e '.[webrtc]'" in err and "\n" not in err
    assert not (tmp_path / "p").exists()

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda n, *a: None if n == "speechmos" else real(n, *a))
    sweep = tmp_path / "d.toml"
    sweep.write_text('[axes]\nenhancers = ["ss"]\nnoise = ["babble"]\nsnr_db = [5]\n[fixed]\nmetrics = ["dnsmos"]\n')
    assert main(["bench", "run", str(sweep), "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip()
    assert 'the metric \'dnsmos\' needs the optional [dnsmos] extra: pip install "scenesim[dnsmos]"' in err
    assert not (tmp_path / "d").exists()
