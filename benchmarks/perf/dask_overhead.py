"""CPU overhead of the Dask executor: a sweep on a local Dask cluster against the local pool.

    python -m benchmarks.perf.dask_overhead [--preset smoke] [--workers 2] [--repeat 1] [--limit N]

Runs ``scenesim bench run PRESET --no-report`` in a fresh process and a fresh store, with
``--executor local --workers 1`` (everything in that one process), ``--executor local
--workers N`` (a fork-server pool) and ``--executor dask --workers N`` (a ``LocalCluster``:
scheduler in the driver, one nanny-supervised worker process per worker), and prints each
run's CPU seconds (user + system of the command and every process it started) and wall
seconds, and the Dask run's excess CPU over the serial run and the pool: what the cluster costs
(worker start-up and imports, scheduler, heartbeats, serialisation).  Then the parts
of that excess measured in this process: starting and closing an idle cluster, and a batch of
no-op tasks on it.  The minimum over ``--repeat`` runs is printed (the least disturbed on a
shared machine) with the load average.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _cpu_self() -> float:
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


def tree_cpu(cmd: list[str], poll_s: float = 0.1) -> tuple[float, float]:
    """``(CPU s, wall s)`` of ``cmd`` and every process it starts, waited for or not.

    Fork-server workers (the local pool's, the Dask cluster's here) are not waited for by
    the command, so ``RUSAGE_CHILDREN`` misses them: the process tree is polled every
    ``poll_s`` instead and each process's last user + system time summed (what a process
    spends after its last poll, at most ``poll_s`` of CPU, is missed).
    """
    import psutil

    wall = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    root = psutil.Process(proc.pid)
    seen: dict[tuple[int, float], float] = {}
    while proc.poll() is None:
        with contextlib.suppress(psutil.Error):
            for p in [root, *root.children(recursive=True)]:
                with contextlib.suppress(psutil.Error):
                    t = p.cpu_times()
                    seen[(p.pid, p.create_time())] = t.user + t.system
        time.sleep(poll_s)
    if proc.returncode:
        raise subprocess.CalledProcessError(proc.returncode, cmd)
    return sum(seen.values()), time.perf_counter() - wall


def time_sweep(preset: str, executor: str, workers: int, limit: int | None) -> tuple[float, float]:
    """``(CPU s, wall s)`` of ``bench run PRESET --executor EXECUTOR`` in a child process tree."""
    with tempfile.TemporaryDirectory(prefix="scenesim-dask-overhead-") as tmp:
        cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", preset, "--out", str(Path(tmp) / "out"),
               "--no-report", "--executor", executor, "--workers", str(workers)]  # fmt: skip
        if limit:
            cmd += ["--limit", str(limit)]
        return tree_cpu(cmd)


def _noop(x):
    return x


def cluster_parts(workers: int, n_tasks: int = 50) -> dict[str, float]:
    """CPU seconds (this process + the cluster's processes) of starting an idle local cluster,
    running ``n_tasks`` no-op tasks on it, idling 5 s, and closing it."""
    from benchmarks.run.executors import DaskExecutor

    out = {}
    t0 = _cpu_self()
    ex = DaskExecutor(workers=workers)
    t1 = _cpu_self()
    out["start (driver)"] = t1 - t0
    list(ex.run(_noop, range(n_tasks)))
    t2 = _cpu_self()
    out[f"{n_tasks} no-op tasks (driver)"] = t2 - t1
    time.sleep(5.0)
    t3 = _cpu_self()
    out["5 s idle (driver)"] = t3 - t2
    out["worker processes (and fork server) so far"] = _descendants_cpu()
    ex.close()
    out["close (driver)"] = _cpu_self() - t3
    return out


def _descendants_cpu() -> float:
    import psutil

    total = 0.0
    for p in psutil.Process().children(recursive=True):
        with contextlib.suppress(psutil.Error):
            t = p.cpu_times()
            total += t.user + t.system
    return total


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="smoke")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--limit", type=int, default=None)
    args = ap.parse_args(argv)
    print(f"load average before: {_load()}")
    runs = {}
    for executor, workers in (("local", 1), ("local", args.workers), ("dask", args.workers)):
        runs[executor, workers] = min((time_sweep(args.preset, executor, workers, args.limit)
                                       for _ in range(args.repeat)), key=lambda t: t[0])  # fmt: skip
        print(f"bench run {args.preset} --executor {executor} --workers {workers}: "
              f"CPU {runs[executor, workers][0]:.2f} s, wall {runs[executor, workers][1]:.1f} s", flush=True)  # fmt: skip
    dask = runs["dask", args.workers][0]
    print(f"Dask excess CPU over the serial run: {dask - runs['local', 1][0]:.2f} s, "
          f"over the local pool: {dask - runs['local', args.workers][0]:.2f} s")  # fmt: skip
    for part, cpu in cluster_parts(args.workers).items():
        print(f"  {part:<34}{cpu:8.2f} s CPU")
    print(f"load average after: {_load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
