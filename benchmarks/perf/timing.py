"""One timing helper for the perf scripts: median wall-clock and CPU time of a call.

>>> wall, cpu = median_time(lambda: sum(range(1000)), runs=3)
>>> wall >= 0 and cpu >= 0
True
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_time(fn: Callable[[], object], runs: int) -> tuple[float, float]:
    """Median wall-clock and median CPU (process) time of ``fn()`` over ``runs`` runs, in seconds.

    One untimed warm-up call first (imports, filter design, caches, JIT).
    """
    fn()
    wall, cpu = [], []
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu)
