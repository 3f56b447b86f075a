"""CPU time of writing a store's report (issue 20's target: `phone` in <= 10 s CPU plus what
the listening page encodes).

    python -m benchmarks.perf.report_time DIR [DIR ...] [--listen-count N] [--repeat R]

For each store, CPU seconds (user + system, so a loaded machine changes the wall time, not
this) of:

* ``process``: the whole ``scenesim bench report DIR --listen-count 0`` command in a child
  process (interpreter start, imports, tables, figures, ``index.html``), the figure a user
  waits for;
* ``in-process``: ``bench report``'s work called from here (modules imported on first use
  included), without audio and then with ``N`` listening conditions (their clips encoded,
  and re-rendered when the sweep did not save them; default 6).

Each is the minimum over ``R`` repeats (default 1): on a shared machine the minimum is the
least disturbed.  Prints the load average before and after.  The store is only read;
``DIR/report`` is rewritten.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path


def time_report(store_dir: Path, count: int) -> tuple[int, float, float]:
    """``(rows, CPU s, wall s)`` of one report of ``store_dir`` with ``count`` listening conditions."""
    from benchmarks.report.from_store import write_store_report
    from benchmarks.report.listening import ListenOptions
    from benchmarks.store.sqlite import ResultStore

    with ResultStore.open(store_dir, readonly=True) as store:
        n = store.count()
    cpu, wall = time.process_time(), time.perf_counter()
    write_store_report(store_dir, listen=ListenOptions(count=count))
    return n, time.process_time() - cpu, time.perf_counter() - wall


def time_process(store_dir: Path) -> tuple[float, float]:
    """``(CPU s, wall s)`` of ``python -m benchmarks.cli.main bench report DIR --listen-count 0``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "report", str(store_dir), "--listen-count", "0"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, time.perf_counter() - wall


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path, metavar="DIR", help="store directories (results.sqlite)")
    ap.add_argument("--listen-count", type=int, default=6, metavar="N", help="listening conditions in the last run")
    ap.add_argument("--repeat", type=int, default=1, metavar="R", help="repeats; the minimum CPU is printed")
    args = ap.parse_args(argv)
    print(f"load average before: {_load()}")
    print(f"{'store':<28}{'rows':>6}{'process CPU s':>15}{'wall s':>8}{'in-proc. CPU s':>16}{'wall s':>8}"
          f"{f'with {args.listen_count} cond.':>16}{'wall s':>8}")  # fmt: skip
    for d in args.dirs:
        proc = min((time_process(d) for _ in range(args.repeat)), key=lambda t: t[0])
        n, cpu0, wall0 = min((time_report(d, 0) for _ in range(args.repeat)), key=lambda t: t[1])
        _, cpu1, wall1 = min((time_report(d, args.listen_count) for _ in range(args.repeat)), key=lambda t: t[1])
        print(f"{str(d)[-28:]:<28}{n:>6}{proc[0]:>15.2f}{proc[1]:>8.1f}{cpu0:>16.2f}{wall0:>8.1f}{cpu1:>16.2f}{wall1:>8.1f}")
    print(f"load average after: {_load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
