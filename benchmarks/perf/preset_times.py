"""Wall time of whole preset runs, as a user starts them: the figures the README quotes.

Each preset runs as ``scenesim bench run NAME --out TMP --workers N --no-report`` in a fresh
process (fresh store, the disk cache of the caller kept, so RIRs and the babble bank are
warm after the first run), ``--repeats`` times; the median is printed with the machine
(cores, CPU model) and the 1-minute load average before each run, because a shared machine
makes absolute times meaningless -- say so when quoting them.

Usage::

    python -m benchmarks.perf.preset_times [thesis phone mismatch ...] [--workers 2] [--repeats 1]
        [--keep DIR]

``--keep DIR`` runs into ``DIR/<preset>`` (which must not exist yet) and keeps the store, so
the timed run's results and report can be read afterwards (``scenesim bench report``).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def cpu_model() -> str:
    """The CPU model name (Linux ``/proc/cpuinfo``), else the platform's processor string."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def time_preset(name: str, *, workers: int, data_dir: str | None = None, out: Path | None = None) -> float:
    """Seconds of one ``bench run`` of preset ``name`` in a fresh process (raises if it fails).

    ``out``: a new directory to run into and keep (default: a temporary one).
    """
    with tempfile.TemporaryDirectory(prefix=f"preset-{name}-") as tmp:
        target = str(out) if out is not None else tmp
        cmd = [sys.executable, "-m", "benchmarks.cli.main", "bench", "run", name, "--out", target,
               "--workers", str(workers), "--no-report"]  # fmt: skip
        if data_dir:
            cmd += ["--data-dir", data_dir]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("presets", nargs="*", default=["thesis", "phone", "mismatch"])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--data-dir", default=None)
    ap.add_argument("--keep", type=Path, default=None, metavar="DIR", help="run into DIR/<preset> and keep it")
    args = ap.parse_args(argv)
    if args.keep is not None and args.repeats != 1:
        ap.error("--keep takes one run per preset (--repeats 1)")
    print(f"machine: {os.cpu_count()} cores, {cpu_model()}; workers {args.workers}; "
          f"data {args.data_dir or 'built-in'}")  # fmt: skip
    print("| preset | runs | median wall (s) | load average before runs |")
    print("|---|---|---|---|")
    for name in args.presets:
        times, loads = [], []
        for _ in range(args.repeats):
            loads.append(os.getloadavg()[0])
            out = None if args.keep is None else args.keep / name
            if out is not None and out.exists():
                ap.error(f"{out} exists: --keep needs fresh directories")
            times.append(time_preset(name, workers=args.workers, data_dir=args.data_dir, out=out))
        load_text = ", ".join(f"{v:.1f}" for v in loads)
        print(f"| {name} | {len(times)} | {statistics.median(times):.1f} | {load_text} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
