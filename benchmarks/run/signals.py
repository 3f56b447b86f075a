"""SIGTERM handled like Ctrl-C, and the interrupted-run message that says what is kept.

``kill PID`` (SIGTERM, what ``timeout``, systemd and batch schedulers send) used to end a
run without stopping its pool workers or marking the run in the store.  Inside
:func:`sigterm_as_interrupt` it raises :class:`Terminated`, a ``KeyboardInterrupt``, so the
same clean-up runs as for Ctrl-C: the executor stops its workers, the store marks the run
``interrupted``, and the CLI prints :class:`RunInterrupted`'s message.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from pathlib import Path


class Terminated(KeyboardInterrupt):
    """Raised in the main thread by SIGTERM within :func:`sigterm_as_interrupt`."""


class RunInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C or SIGTERM; ``str()`` says how many rows are kept and how to resume.

    Parameters
    ----------
    terminated : bool
        True for SIGTERM, False for Ctrl-C (SIGINT).
    n_written : int
        Rows this run wrote before it stopped.
    n_stored : int
        Rows in the store now (earlier runs included).
    store_path : Path
    """

    def __init__(self, terminated: bool, n_written: int, n_stored: int, store_path):
        self.terminated = bool(terminated)
        self.n_written = int(n_written)
        self.n_stored = int(n_stored)
        self.store_path = Path(store_path)
        super().__init__(self.terminated, self.n_written, self.n_stored, str(self.store_path))

    def __str__(self) -> str:
        how = "terminated (SIGTERM)" if self.terminated else "interrupted"
        return (
            f"{how}: {self.n_stored} row(s) kept in {self.store_path} ({self.n_written} from this run); "
            "rerun the same command to resume"
        )

    @property
    def exit_code(self) -> int:
        """128 + the signal number, as a shell reports a process killed by it."""
        return 128 + (signal.SIGTERM if self.terminated else signal.SIGINT)


def interrupted(exc: KeyboardInterrupt, *, n_written: int, n_stored: int, store_path) -> RunInterrupted:
    """The :class:`RunInterrupted` for ``exc`` (Ctrl-C or :class:`Terminated`)."""
    return RunInterrupted(isinstance(exc, Terminated), n_written, n_stored, store_path)


def _raise_terminated(signum, frame):
    raise Terminated()


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread (like Ctrl-C).

    Outside the main thread (signal handlers can only be set there) it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
