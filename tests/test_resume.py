"""Kill-and-resume: ``kill -9`` a running sweep, rerun it, and lose / duplicate / recompute nothing."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time

from benchmarks.cli.main import main
from benchmarks.run.sweep import load_sweep

# Long enough to be caught mid-run (8 conditions), short per unit (1 s signals, no babble
# synthesis), so the whole test takes seconds.
SWEEP = """\
[sweep]
name = "resume"

[axes]
enhancers = ["passthrough", "eb"]
noise = ["wind", "factory"]
snr_db = [0, 5, 10, 15]

[fixed]
duration_s = 1.0
"""


def stored_rows(path) -> list[tuple]:
    """``(condition_id, enhancer, created_at)`` of every row; [] before the store exists."""
    if not path.exists():
        return []
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5)
        try:
            return list(db.execute("SELECT condition_id, enhancer, created_at FROM results"))
        finally:
            db.close()
    except sqlite3.OperationalError:  # table not created yet
        return []


def test_kill_9_mid_sweep_then_resume(tmp_path):
    sweep_file = tmp_path / "resume.toml"
    sweep_file.write_text(SWEEP)
    sweep = load_sweep(sweep_file)
    total = len(sweep.conditions()) * len(sweep.enhancers)
    out = tmp_path / "out"
    store = out / "results.sqlite"
    cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", str(sweep_file),
           "--out", str(out), "--workers", "2", "--no-report"]  # fmt: skip
    log = open(tmp_path / "run.log", "wb")
    # Own session: killpg reaches the driver and its pool's worker processes alike.
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 90
        while len(stored_rows(store)) == 0:
            assert proc.poll() is None, (tmp_path / "run.log").read_text()
            assert time.monotonic() < deadline, "no row within 90 s"
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        log.close()
    assert proc.returncode == -signal.SIGKILL

    before = stored_rows(store)
    n_before = len(before)
    assert 0 < n_before < total, f"killed after {n_before} of {total} rows: the sweep must be caught mid-run"
    # a unit is committed whole: every stored condition has all its enhancers
    per_condition = {}
    for cid, enh, _ in before:
        per_condition.setdefault(cid, set()).add(enh)
    assert all(len(v) == len(sweep.enhancers) for v in per_condition.values())

    assert main(["bench", "run", str(sweep_file), "--out", str(out), "--workers", "1", "--no-report"]) == 0

    after = stored_rows(store)
    assert len(after) == total
    assert len({(c, e) for c, e, _ in after}) == total  # no duplicates
    created = {(c, e): t for c, e, t in after}
    for cid, enh, t in before:  # rows committed before the kill were not recomputed
        assert created[(cid, enh)] == t
    db = sqlite3.connect(store)
    try:
        assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        statuses = [r[0] for r in db.execute("SELECT status FROM runs ORDER BY started_at")]
        n_second = db.execute(
            "SELECT n_rows_written FROM runs ORDER BY started_at DESC LIMIT 1"
        ).fetchone()[0]
        assert {r[0] for r in db.execute("SELECT status FROM results")} == {"ok"}
    finally:
        db.close()
    assert statuses == ["killed", "finished"]  # the killed run never finished: marked by the next one
    assert n_second == total - n_before
