"""One run per output directory: a lock file that a second run refuses, and a killed run frees.

Two ``scenesim bench run`` on one ``--out`` would both compute every missing row (the
store only dedupes on write).  :func:`run_lock` takes an exclusive ``fcntl.flock`` on
``DIR/.scenesim-run.lock`` for the duration of a run and writes the holder's pid, host and
start time into it, so a second run can say who holds it.  The kernel drops a flock when
its process dies, ``kill -9`` included: the lock file of a killed run stays behind but is
not held, and the next run takes it over and says so (a stale lock is cleared).
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

from scenesim.errors import ScenesimError

LOCK_NAME = ".scenesim-run.lock"

try:  # POSIX; elsewhere runs are not locked (documented limitation)
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


class RunLockedError(ScenesimError):
    """Another run holds the output directory's lock."""


def _holder(text: str) -> dict:
    try:
        info = json.loads(text)
    except ValueError:
        return {}
    return info if isinstance(info, dict) else {}


@contextlib.contextmanager
def run_lock(out_dir, *, option: str = "--out") -> Iterator[Path]:
    """Hold ``out_dir``'s run lock within the block; raise :class:`RunLockedError` if a live run has it.

    A lock file left by a run that was killed (its lock no longer held) is taken over with
    a warning naming the old pid.
    """
    path = Path(out_dir) / LOCK_NAME
    if fcntl is None:  # pragma: no cover
        yield path
        return
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            info = _holder(os.pread(fd, 4096, 0).decode("utf-8", "replace"))
            who = f"pid {info.get('pid', '?')} on {info.get('host', '?')}, started {info.get('started', '?')}"
            raise RunLockedError(
                f"another run ({who}) is writing to {out_dir}; wait for it to finish or choose another "
                f"{option} (rerunning afterwards resumes)"
            ) from None
        old = _holder(os.pread(fd, 4096, 0).decode("utf-8", "replace"))
        if old.get("pid"):
            warnings.warn(
                f"cleared a stale run lock in {out_dir} (pid {old['pid']} on {old.get('host', '?')} "
                "ended without releasing it, e.g. killed); its stored rows are kept",
                stacklevel=3,
            )
        me = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%dT%H:%M:%S")}
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(me).encode(), 0)
        try:
            yield path
        finally:
            os.ftruncate(fd, 0)  # released cleanly: an empty file is not stale
    finally:
        os.close(fd)  # closing drops the flock
