"""Dask: a real ``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1.

``smoke`` through ``--executor dask --scheduler`` gives the same numbers as the local run;
killing a worker mid-sweep loses nothing (Dask reschedules its tasks on the survivor).
"""

from __future__ import annotations

import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _bench_smoke import local_smoke_run

from benchmarks.cli.main import main
from benchmarks.run.sweep import load_sweep

pytest.importorskip("distributed", reason="dask[distributed] is in the dev extra")

DASK = Path(sys.executable).parent / "dask"
METRICS = ("snr_out_db", "snr_i_db", "pesq_nb_in", "pesq_nb_out", "pesq_wb_in", "pesq_wb_out",
           "stoi_in", "stoi_out", "estoi_out", "si_sdr_out_db")  # fmt: skip

# Enough units to kill a worker while most are still queued; wind/factory only (no babble
# synthesis) and 1 s signals keep each unit short.
KILL_SWEEP = """\
[sweep]
name = "dask-kill"

[axes]
enhancers = ["passthrough", "eb"]
noise = ["wind", "factory"]
snr_db = [0, 3, 6, 9, 12, 15]

[fixed]
duration_s = 1.0
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _kill(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(timeout=30)


def _rows(store: Path) -> list[dict]:
    if not store.exists():
        return []
    try:
        db = sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=5)
        db.row_factory = sqlite3.Row
        try:
            return [dict(r) for r in db.execute("SELECT * FROM results")]
        finally:
            db.close()
    except sqlite3.OperationalError:
        return []


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """``(address, [worker processes])``: a scheduler and two single-threaded workers."""
    from distributed import Client

    logs = tmp_path_factory.mktemp("dask-logs")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []

    def start(args, name):
        # Own session each: killpg takes a worker's nanny and its worker process together.
        log = open(logs / f"{name}.log", "wb")
        procs.append(subprocess.Popen([str(DASK), *args], stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
        log.close()
        return procs[-1]

    try:
        start(["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], "scheduler")
        workers = [
            start(["worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                   "--host", "127.0.0.1", "--name", f"w{i}"], f"worker{i}")  # fmt: skip
            for i in range(2)
        ]
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=90)
        yield address, workers
    finally:
        for p in reversed(procs):
            _kill(p)


def test_smoke_on_dask_matches_the_local_run(cluster, tmp_path, tmp_path_factory):
    """Oracle: the local run of the same sweep (same seeds, same code): equal to 1e-9."""
    address, _ = cluster
    assert main(["bench", "run", "smoke", "--out", str(tmp_path / "dask"), "--executor", "dask",
                 "--scheduler", address, "--no-report"]) == 0  # fmt: skip
    code, local_dir = local_smoke_run(tmp_path_factory)
    assert code == 0
    on_dask = {(r["condition_id"], r["enhancer"]): r for r in _rows(tmp_path / "dask" / "results.sqlite")}
    local = {(r["condition_id"], r["enhancer"]): r for r in _rows(local_dir / "results.sqlite")}
    sweep = load_sweep("smoke")
    assert len(on_dask) == len(sweep.conditions()) * len(sweep.enhancers) == len(local)
    assert on_dask.keys() == local.keys()
    assert {r["status"] for r in on_dask.values()} == {"ok"}
    # the work really ran in the worker processes, not in this one
    assert all(not r["worker"].endswith(f":{os.getpid()}") for r in on_dask.values())
    _assert_same_metrics(on_dask, local)


def test_killing_a_worker_mid_sweep_loses_nothing(cluster, tmp_path):
    address, workers = cluster
    sweep_file = tmp_path / "kill.toml"
    sweep_file.write_text(KILL_SWEEP)
    sweep = load_sweep(sweep_file)
    total = len(sweep.conditions()) * len(sweep.enhancers)
    out = tmp_path / "out"
    store = out / "results.sqlite"
    log = open(tmp_path / "driver.log", "wb")
    driver = subprocess.Popen(
        [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", str(sweep_file), "--out", str(out),
         "--executor", "dask", "--scheduler", address, "--no-report"],  # fmt: skip
        stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
    )
    log.close()
    try:
        deadline = time.monotonic() + 90
        while not _rows(store):
            assert driver.poll() is None, (tmp_path / "driver.log").read_text()
            assert time.monotonic() < deadline, "no row within 90 s"
            time.sleep(0.02)
        n_at_kill = len(_rows(store))
        _kill(workers[0])  # SIGKILL nanny + worker: its running task is lost mid-flight
        driver.wait(timeout=120)
    finally:
        _kill(driver)
    text = (tmp_path / "driver.log").read_text()
    assert driver.returncode == 0, text
    rows = _rows(store)
    assert n_at_kill < total, "the sweep finished before the kill: make it longer"
    assert len(rows) == total and len({(r["condition_id"], r["enhancer"]) for r in rows}) == total
    assert {r["status"] for r in rows} == {"ok"}, [r["error"] for r in rows if r["status"] != "ok"]


def test_a_local_cluster_forks_its_workers_and_matches_the_local_run(tmp_path, tmp_path_factory):
    """``--executor dask`` without a scheduler: a LocalCluster whose workers fork from a warm
    fork server (LOCAL_CLUSTER_CONFIG); oracle: the local run, equal to 1e-9."""
    from benchmarks.run.executors import DaskExecutor

    ex = DaskExecutor(workers=1)
    try:
        (_, method), = ex.run(_worker_setting, ["distributed.worker.multiprocessing-method"])
        (_, profile), = ex.run(_worker_setting, ["distributed.worker.profile.enabled"])
        assert (method, profile) == ("forkserver", False)
        (_, parent), = ex.run(_parent_pid, [None])
        assert parent != os.getpid()  # forked by the fork server, not spawned by this process's nanny
    finally:
        ex.close()
    out = tmp_path / "dask-local"
    assert main(["bench", "run", "smoke", "--out", str(out), "--executor", "dask", "--workers", "2", "--no-report"]) == 0
    code, local_dir = local_smoke_run(tmp_path_factory)
    assert code == 0
    on_dask = {(r["condition_id"], r["enhancer"]): r for r in _rows(out / "results.sqlite")}
    local = {(r["condition_id"], r["enhancer"]): r for r in _rows(local_dir / "results.sqlite")}
    assert on_dask.keys() == local.keys() and {r["status"] for r in on_dask.values()} == {"ok"}
    assert all(not r["worker"].endswith(f":{os.getpid()}") for r in on_dask.values())
    _assert_same_metrics(on_dask, local)
    assert len(list((out / "listen_audio").glob("*.npz"))) == len(load_sweep("smoke").conditions())


def _assert_same_metrics(on_dask: dict, local: dict) -> None:
    """Every metric of every row equal to the local run's to 1e-9 (None where it is None)."""
    for key, r in local.items():
        for m in METRICS:
            a, b = r[m], on_dask[key][m]
            assert (a is None) == (b is None), (key, m)
            if a is not None:
                np.testing.assert_allclose(b, a, rtol=0, atol=1e-9, err_msg=f"{key} {m}")


def _worker_setting(key):
    import dask

    return dask.config.get(key)


def _parent_pid(_):
    return os.getppid()
