"""Progress of a sweep when stderr is not a terminal (a log file, CI, ``nohup``), and slow-RIR hints.

tqdm draws a bar on a terminal and switches itself off elsewhere, leaving a long run
silent.  :class:`LineProgress` prints a start line (conditions, workers) and then one line
every ``interval_s`` seconds from a daemon thread, whether or not a condition finished.
:func:`slow_rir_warning` warns before a sweep whose rooms will take long to render.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Sequence

# The image-source count grows with the RIR length cubed and falls with the room volume.
# Calibration point (issue 11): RT60 5 s in the 56 m^3 "living" room took ~280 s to render
# on one core of the reference machine.
SLOW_RIR_REF = (5.0, 56.0, 280.0)  # (rt60_s, volume_m3, seconds)
SLOW_RIR_WARN_S = 60.0


def estimated_rir_seconds(rt60_s: float, volume_m3: float) -> float:
    """Rough render time (s) of one condition's RIRs: ``280 s (T/5 s)^3 (56 m^3 / V)``."""
    t_ref, v_ref, s_ref = SLOW_RIR_REF
    return s_ref * (rt60_s / t_ref) ** 3 * (v_ref / volume_m3)


def slow_rir_warning(conditions: Sequence, *, threshold_s: float = SLOW_RIR_WARN_S) -> str | None:
    """A one-line hint naming the conditions whose RIRs will take over ``threshold_s`` each, or None."""
    slow = []
    for c in conditions:
        dims = getattr(c, "room_dims_m", None)
        if dims and c.rt60_s > 0:
            est = estimated_rir_seconds(c.rt60_s, dims[0] * dims[1] * dims[2])
            if est > threshold_s:
                slow.append((est, c.rt60_s))
    if not slow:
        return None
    worst, rt60 = max(slow)
    return (
        f"{len(slow)} condition(s) with long reverberation (up to RT60 {rt60:g} s) will take about "
        f"{worst / 60:.0f} min each to render their room impulse responses (once; then cached)"
    )


class LineProgress:
    """A progress reporter for non-terminals: a start line, then a line every ``interval_s`` seconds.

    Has the part of tqdm's interface the runner uses (context manager, ``update``,
    ``set_postfix``).
    """

    def __init__(self, total: int, name: str, *, workers: int | None = None, interval_s: float = 10.0,
                 stream=None):
        self.total, self.name, self.workers = int(total), name, workers
        self.interval_s = float(interval_s)
        self.stream = stream or sys.stderr
        self.n = 0
        self.errors = 0
        self._t0 = time.monotonic()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._beat, name="scenesim-progress", daemon=True)

    def _say(self, text: str) -> None:
        print(f"scenesim bench: {self.name}: {text}", file=self.stream, flush=True)

    def line(self) -> str:
        """``"3/36 conditions (8 %), 0 errors, 42 s elapsed, ~462 s left"``."""
        with self._lock:
            n, errors = self.n, self.errors
        elapsed = time.monotonic() - self._t0
        left = f", ~{elapsed * (self.total - n) / n:.0f} s left" if n else ""
        pct = 100.0 * n / self.total if self.total else 100.0
        # Conditions are counted as their block (a geometry group) finishes: until the first one
        # does, say that work is under way rather than let "0 %" read as a hang.
        busy = ": the first block of conditions is computing" if n == 0 and self.total else ""
        return f"{n}/{self.total} conditions ({pct:.0f} %){busy}, {errors} errors, {elapsed:.0f} s elapsed{left}"

    def _beat(self) -> None:
        while not self._stop.wait(self.interval_s):
            self._say(self.line())

    def __enter__(self) -> LineProgress:
        workers = f" on {self.workers} worker(s)" if self.workers else ""
        self._say(f"{self.total} condition(s) to compute{workers}; a progress line every {self.interval_s:g} s")
        self._thread.start()
        return self

    def update(self, n: int = 1) -> None:
        with self._lock:
            self.n += n

    def set_postfix(self, errors: int = 0, refresh: bool = False, **_) -> None:
        with self._lock:
            self.errors = int(errors)

    def __exit__(self, *exc) -> bool:
        self._stop.set()
        self._thread.join(timeout=1.0)
        if exc[0] is None:
            self._say(self.line())
        return False
