"""CPU time of writing a store's report (issue 20's target: `phone` in <= 10 s CPU plus what
the listening page encodes).

    python -m benchmarks.perf.report_time DIR [DIR ...] [--listen-count N]

For each store: ``bench report``'s work (tables, figures, ``index.html``) timed with
``time.process_time`` (this process's CPU, so a loaded machine changes the wall time, not
this), first without audio (``--listen-count 0``), then with ``N`` listening conditions
(re-rendered and encoded; default 6).  Prints rows, CPU and wall seconds and the load average.
"""

from __future__ import annotations

import argparse
import os
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path, metavar="DIR", help="store directories (results.sqlite)")
    ap.add_argument("--listen-count", type=int, default=6, metavar="N", help="listening conditions in the second run")
    args = ap.parse_args(argv)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'store':<28}{'rows':>6}{'CPU s (no audio)':>18}{'wall s':>8}{f'CPU s ({args.listen_count} cond.)':>18}{'wall s':>8}")
    for d in args.dirs:
        n, cpu0, wall0 = time_report(d, 0)
        _, cpu1, wall1 = time_report(d, args.listen_count)
        print(f"{str(d)[-28:]:<28}{n:>6}{cpu0:>18.2f}{wall0:>8.1f}{cpu1:>18.2f}{wall1:>8.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
