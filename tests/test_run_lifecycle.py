"""A sweep's life: one run per --out, SIGTERM like Ctrl-C, no orphans after kill -9, progress in logs.

Regression tests for issue 11: a SIGTERM'd run left its workers running and the run
unmarked; each ``kill -9`` left four Python processes behind for good; two runs on one
``--out`` computed everything twice; a run logging to a file printed nothing for minutes.
"""

from __future__ import annotations

import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from benchmarks.cli.main import main
from benchmarks.run.lock import LOCK_NAME, RunLockedError, run_lock
from benchmarks.run.progress import LineProgress, estimated_rir_seconds, slow_rir_warning
from benchmarks.run.signals import RunInterrupted, Terminated, interrupted
from benchmarks.run.watchdog import process_alive

linux_only = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")


# -- lock ------------------------------------------------------------------------------
def test_second_run_on_one_out_refuses_naming_the_holder(tmp_path):
    with run_lock(tmp_path):
        with pytest.raises(RunLockedError, match=rf"another run \(pid {os.getpid()} on .*\) is writing to"):
            with run_lock(tmp_path):
                pass
    with run_lock(tmp_path):  # released: free again, and no stale-lock warning
        pass


def test_cli_second_run_refuses_before_computing(tmp_path, capsys):
    with run_lock(tmp_path):
        argv = ["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--out", str(tmp_path)]
        assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("scenesim: error: another run (pid"), err
    assert not (tmp_path / "results.sqlite").exists()


def test_stale_lock_of_a_killed_run_is_cleared_with_a_warning(tmp_path):
    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": 999999, "host": "h", "started": "t"}))
    with pytest.warns(UserWarning, match=r"cleared a stale run lock .*pid 999999"):
        with run_lock(tmp_path):
            holder = json.loads((tmp_path / LOCK_NAME).read_text())
            assert holder["pid"] == os.getpid()
    assert (tmp_path / LOCK_NAME).read_text() == ""  # a clean release leaves nothing stale


# -- messages --------------------------------------------------------------------------
def test_interrupt_messages_say_rows_kept_and_how_to_resume(tmp_path):
    store = tmp_path / "results.sqlite"
    ctrl_c = interrupted(KeyboardInterrupt(), n_written=3, n_stored=10, store_path=store)
    term = interrupted(Terminated(), n_written=3, n_stored=10, store_path=store)
    for exc in (ctrl_c, term):
        assert isinstance(exc, RunInterrupted) and isinstance(exc, KeyboardInterrupt)
        assert f"10 row(s) kept in {store} (3 from this run); rerun the same command to resume" in str(exc)
    assert str(ctrl_c).startswith("interrupted") and ctrl_c.exit_code == 130
    assert str(term).startswith("terminated (SIGTERM)") and term.exit_code == 143


# -- watchdog --------------------------------------------------------------------------
@linux_only
def test_process_alive_treats_an_unreaped_zombie_as_dead():
    assert process_alive(os.getpid())
    child = subprocess.Popen(["true"])
    deadline = time.monotonic() + 10
    while process_alive(child.pid) and time.monotonic() < deadline:
        time.sleep(0.05)  # `true` exits at once; until wait() it is a zombie
    assert not process_alive(child.pid)
    child.wait()


_ORPHAN_SCRIPT = """
import os, sys, time
from benchmarks.run.watchdog import exit_when_orphaned
pid = os.fork()
if pid == 0:  # the 'worker': watches its parent, the 'driver'
    exit_when_orphaned(os.getppid(), interval_s=0.1)
    time.sleep(60)
    os._exit(0)
print(pid, flush=True)
time.sleep(60)
"""


def test_worker_exits_within_seconds_after_its_driver_is_killed():
    driver = subprocess.Popen([sys.executable, "-c", _ORPHAN_SCRIPT], stdout=subprocess.PIPE, text=True)
    worker = int(driver.stdout.readline())
    time.sleep(0.5)  # ~5 checks by the watchdog: it leaves a worker alone while the driver lives
    assert process_alive(worker)
    driver.kill()
    driver.wait()
    deadline = time.monotonic() + 5
    while process_alive(worker) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not process_alive(worker), "the orphaned worker is still running"


# -- progress --------------------------------------------------------------------------
def test_line_progress_prints_a_start_line_and_regular_lines():
    out = io.StringIO()
    with LineProgress(4, "smoke", workers=2, interval_s=0.05, stream=out) as bar:
        bar.update(1)
        bar.set_postfix(errors=1)
        time.sleep(0.3)
    lines = out.getvalue().splitlines()
    assert lines[0] == "scenesim bench: smoke: 4 condition(s) to compute on 2 worker(s); a progress line every 0.05 s"
    beats = [ln for ln in lines[1:] if "1/4 conditions (25 %), 1 errors" in ln]
    assert len(beats) >= 3, lines  # ~6 intervals passed; the load may delay some


@pytest.mark.slow
def test_run_logging_to_a_file_prints_progress(tmp_path, capsys):
    assert main(["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--no-report",
                 "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err  # capsys: not a terminal
    assert "scenesim bench: smoke: 1 condition(s) to compute on 1 worker(s)" in err
    assert "scenesim bench: smoke: 1/1 conditions (100 %), 0 errors" in err


def test_slow_rir_warning_before_long_reverberation():
    living = (5.0, 4.0, 2.8)
    assert estimated_rir_seconds(5.0, 56.0) == pytest.approx(280.0)  # the calibration point
    quick = [SimpleNamespace(rt60_s=t, room_dims_m=living) for t in (0.0, 0.5, 1.0)]
    assert slow_rir_warning(quick) is None
    anechoic = [SimpleNamespace(rt60_s=0.0, room_dims_m=None)]
    slow = [SimpleNamespace(rt60_s=5.0, room_dims_m=living), *quick, *anechoic]
    assert slow_rir_warning(slow) == (
        "1 condition(s) with long reverberation (up to RT60 5 s) will take about 5 min each to "
        "render their room impulse responses (once; then cached)"
    )


# -- whole runs: SIGTERM and kill -9 ----------------------------------------------------
def _descendants(pid: int) -> set[int]:
    psutil = pytest.importorskip("psutil")
    try:
        return {p.pid for p in psutil.Process(pid).children(recursive=True)}
    except psutil.NoSuchProcess:
        return set()


def _start_pool_run(tmp_path):
    cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", "thesis", "--limit", "12",
           "--workers", "2", "--no-report", "--out", str(tmp_path)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    kids: set[int] = set()
    while time.monotonic() < deadline:  # fork server + resource tracker + 2 workers
        kids = _descendants(proc.pid)
        if len(kids) >= 4:
            break
        time.sleep(0.2)
    assert len(kids) >= 4, f"pool never started: {proc.communicate(timeout=60)}"
    time.sleep(1.0)  # the workers are busy with their first units
    return proc, kids


def _gone_within(pids: set[int], seconds: float) -> set[int]:
    deadline = time.monotonic() + seconds
    alive = set(pids)
    while alive and time.monotonic() < deadline:
        alive = {p for p in alive if process_alive(p)}
        time.sleep(0.1)
    return alive


@pytest.mark.slow
@linux_only
def test_sigterm_stops_workers_marks_run_and_says_rows_kept(tmp_path):
    proc, kids = _start_pool_run(tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "scenesim: terminated (SIGTERM):" in err and "rerun the same command to resume" in err, err
    assert "leaked semaphore" not in err and "Traceback" not in err, err
    assert not _gone_within(kids, 5.0), "worker processes outlived the run"
    status = sqlite3.connect(tmp_path / "results.sqlite").execute("SELECT status FROM runs").fetchall()
    assert status == [("interrupted",)]


@pytest.mark.slow
@linux_only
def test_kill_9_leaves_no_orphan_processes(tmp_path):
    proc, kids = _start_pool_run(tmp_path)
    proc.kill()
    proc.communicate(timeout=60)
    assert not _gone_within(kids, 10.0), "pool processes outlived a killed run"


@pytest.mark.skipif(not hasattr(signal, "SIGALRM"), reason="needs SIGALRM")
def test_interrupt_terminates_busy_workers_instead_of_waiting_for_them():
    from benchmarks.run.executors import LocalExecutor

    ex = LocalExecutor(workers=1)
    old = signal.signal(signal.SIGALRM, signal.default_int_handler)  # SIGALRM -> KeyboardInterrupt
    try:
        signal.alarm(1)
        with pytest.raises(KeyboardInterrupt):
            for _ in ex.run(time.sleep, [60.0]):  # a unit that would take a minute
                pass
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    t0 = time.monotonic()
    ex.close()
    assert time.monotonic() - t0 < 10.0, "close() waited for the busy worker"


@pytest.mark.parametrize("outcome", ["finished", "refused"])
def test_the_callers_sigterm_and_sigint_handlers_are_back_after_a_run(outcome, tmp_path, capsys):
    # Oracle: identity.  A notebook or service that set its own handlers gets exactly those back
    # after `scenesim bench run` returns, whether the run finished or was refused mid-way.
    def mine(signum, frame):  # pragma: no cover - never called
        pass

    def other(signum, frame):  # pragma: no cover - never called
        pass

    before = signal.signal(signal.SIGTERM, mine), signal.signal(signal.SIGINT, other)
    try:
        args = ["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--no-report", "--out", str(tmp_path)]
        if outcome == "refused":
            args += ["--seeds", "100000000"]
        main(args)
        assert signal.getsignal(signal.SIGTERM) is mine and signal.getsignal(signal.SIGINT) is other
    finally:
        signal.signal(signal.SIGTERM, before[0])
        signal.signal(signal.SIGINT, before[1])
