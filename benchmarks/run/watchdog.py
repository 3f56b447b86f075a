"""Pool workers that exit when the run that started them is gone (``kill -9`` leaves no orphans).

A killed driver cannot stop its workers; they would wait forever on their task queue,
whose write end they hold themselves.  :func:`exit_when_orphaned` runs as the pool's
initializer: a daemon thread checks every ``interval_s`` seconds whether the driver is
still alive and whether the worker's own parent (the fork server) is still the same, and
ends the worker with ``os._exit`` when not.
"""

from __future__ import annotations

import os
import threading
import time

CHECK_INTERVAL_S = 1.0


def process_alive(pid: int) -> bool:
    """True if ``pid`` runs and is not a zombie (a killed process its parent has not reaped)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    try:
        with open(f"/proc/{pid}/stat") as fh:  # Linux: field 3 is the state, Z = zombie
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True  # no /proc (macOS): os.kill's answer stands


def exit_when_orphaned(driver_pid: int, interval_s: float = CHECK_INTERVAL_S) -> None:
    """Pool initializer: start a daemon thread that ends this process once ``driver_pid`` is gone."""
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(interval_s)
            if os.getppid() != parent or not process_alive(driver_pid):
                os._exit(70)  # EX_SOFTWARE; nobody is left to read a result

    threading.Thread(target=watch, name="scenesim-orphan-watchdog", daemon=True).start()
