"""Where units of work run: in this process, a local process pool, or a Dask cluster.

Every executor has one method, ``run(fn, tasks) -> iterator of (task, outcome)``, that
yields each task's outcome *as it finishes* (any order) so the driver can store it at
once.  ``outcome`` is ``fn(task)``'s return value, or the exception that the executor
got instead (a task the cluster gave up on).  ``fn`` must be a picklable module-level
function and, for results to be identical whichever executor ran them, a pure function
of its task.

* :class:`SerialExecutor` -- one worker: no pool, no pickling, easiest to debug.
* :class:`LocalExecutor` -- ``concurrent.futures.ProcessPoolExecutor`` (workers default
  to ``os.cpu_count()``); a dead worker process breaks the pool, which raises
  :class:`ExecutorError` (rerunning resumes).
* :class:`DaskExecutor` -- ``distributed.Client(scheduler)`` when an address is given,
  otherwise a ``LocalCluster`` of single-threaded worker processes on 127.0.0.1, forked
  from a warm fork server like the local pool's (:data:`LOCAL_CLUSTER_CONFIG`).  Dask
  reschedules the tasks of a worker that dies; a task that kills
  ``distributed.scheduler.allowed-failures`` workers comes back as ``KilledWorker``.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from benchmarks.metrics.scoring import MAX_WORKERS
from benchmarks.run.watchdog import exit_when_orphaned
from scenesim.errors import ParameterError, ScenesimError

EXECUTORS = ("local", "dask")


class ExecutorError(ScenesimError):
    """The execution machinery failed (a pool broke, the cluster is unreachable)."""


class SerialExecutor:
    """Run tasks one after another in this process."""

    name = "local"
    workers = 1

    def run(self, fn: Callable[[Any], Any], tasks: Sequence[Any]) -> Iterator[tuple[Any, Any]]:
        for task in tasks:
            yield task, fn(task)

    def close(self) -> None:
        pass


class LocalExecutor:
    """A pool of ``workers`` processes on this machine, started when constructed.

    Workers are forked from a ``forkserver`` (not from this process: forking a process that
    runs threads, e.g. a progress bar's monitor, can deadlock a child on a lock held
    mid-fork).  The fork server imports ``preload`` once, so workers start warm, and runs
    with single-threaded BLAS/OpenMP (unless the user set those variables): a worker per
    core plus a BLAS thread pool per worker oversubscribes the cores (measured on the
    thesis preset with 2 workers on 2 cores: 24 s with default threads, 17 s with one).
    At most ``2 * workers`` tasks are submitted ahead, so a kill loses little and memory
    stays flat on large sweeps.
    """

    name = "local"

    def __init__(self, workers: int | None = None, *, preload: Sequence[str] = ()):
        self.workers = check_workers(workers)
        self.preload = tuple(preload)
        ctx = multiprocessing.get_context("forkserver")
        if self.preload:
            ctx.set_forkserver_preload(list(self.preload))
        # Workers end themselves once this process is gone (kill -9 leaves no orphans).
        self._pool = ProcessPoolExecutor(
            max_workers=self.workers, mp_context=ctx, initializer=exit_when_orphaned, initargs=(os.getpid(),)
        )
        with _environ(SINGLE_THREAD_ENV):
            # Launch every worker now: the fork server starts with this environment.
            for fut in [self._pool.submit(_ready) for _ in range(self.workers)]:
                fut.result()

    def run(self, fn, tasks) -> Iterator[tuple[Any, Any]]:
        # Ctrl-C or SIGTERM while waiting here, or the caller abandoning the loop (an
        # exception in its body closes this generator): stop the workers now, so that
        # close() does not wait for tasks nobody will read.
        try:
            yield from self._run(fn, tasks)
        except (KeyboardInterrupt, GeneratorExit):
            self.terminate_workers()
            raise

    def terminate_workers(self) -> None:
        """SIGTERM every worker process of the pool (their tasks are lost; the pool is broken)."""
        for proc in list((getattr(self._pool, "_processes", None) or {}).values()):
            with contextlib.suppress(OSError, ValueError):
                proc.terminate()

    def _run(self, fn, tasks) -> Iterator[tuple[Any, Any]]:
        pending = list(tasks)[::-1]
        running: dict[Any, Any] = {}
        pool = self._pool
        while pending or running:
            while pending and len(running) < 2 * self.workers:
                task = pending.pop()
                running[pool.submit(fn, task)] = task
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in done:
                task = running.pop(fut)
                try:
                    outcome = fut.result()
                except BrokenProcessPool as exc:
                    raise ExecutorError(
                        "a worker process died (out of memory or killed?); "
                        "rerun the same command to compute what is missing"
                    ) from exc
                except Exception as exc:  # fn raised: hand it to the driver
                    outcome = exc
                yield task, outcome

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


def _ready() -> bool:
    return True


SINGLE_THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""Thread-pool sizes for worker processes (Dask's nanny sets the same by default)."""


@contextlib.contextmanager
def _environ(values: dict[str, str]):
    """Set environment variables the user has not set, for the duration of the block."""
    added = [k for k in values if k not in os.environ]
    for k in added:
        os.environ[k] = values[k]
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)


#: Dask settings of the local cluster (``benchmarks.perf.dask_overhead`` measures them).
#: Its worker processes are forked from a fork server that imported the sweep's modules once
#: (Dask's default spawns each one fresh, and each then imports numpy, scipy, the enhancers
#: and the metrics again: about half of the ~12 s CPU a 2-worker ``smoke`` run on Dask cost
#: beyond the serial run).  Idle housekeeping is slowed from Dask's defaults, which cost
#: ~0.1 CPU-second per second of the run with 2 workers (~0.017 after): the event-loop
#: health check of every server (20 ms), the psutil system monitor (500 ms) and the nannies'
#: memory monitor (100 ms; a worker past its memory limit is still stopped within 1 s).
#: The workers' statistical profiler (a stack sample every 10 ms, for the dashboard, which
#: is off) is off.  A cluster given by address keeps its own settings.
LOCAL_CLUSTER_CONFIG = {
    "distributed.worker.multiprocessing-method": "forkserver",
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
}


class DaskExecutor:
    """Run tasks on Dask: an existing scheduler (``scheduler="tcp://host:port"``) or a local cluster.

    ``preload``: modules the local cluster's fork server imports once (ignored with a scheduler).
    """

    name = "dask"

    def __init__(self, workers: int | None = None, scheduler: str | None = None, *, preload: Sequence[str] = ()):
        try:
            import dask
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - dask is an optional extra
            raise ExecutorError(
                "the dask executor needs dask[distributed]: pip install 'dask[distributed]' "
                "(or, in a scenesim checkout: pip install -e '.[dask]')"
            ) from exc
        self.scheduler = scheduler
        self._cluster = None
        try:
            if scheduler:
                self._client = Client(scheduler, timeout="30s")
                self.workers = len(self._client.scheduler_info().get("workers", {})) or None
            else:
                self.workers = check_workers(workers)
                with dask.config.set(LOCAL_CLUSTER_CONFIG), _environ(SINGLE_THREAD_ENV):
                    _forkserver_preload(preload)
                    self._cluster = LocalCluster(
                        n_workers=self.workers,
                        threads_per_worker=1,
                        processes=True,
                        host="127.0.0.1",
                        dashboard_address=None,
                        # The scheduler's HTTP endpoint (health, metrics) on any free port:
                        # its default 8787 warns on stderr whenever another cluster holds it.
                        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                    )
                self._client = Client(self._cluster)
        except (OSError, TimeoutError) as exc:
            self.close()
            raise ExecutorError(f"cannot reach the Dask scheduler {scheduler or '(local)'}: {exc}") from exc

    def run(self, fn, tasks) -> Iterator[tuple[Any, Any]]:
        from distributed import as_completed

        tag = uuid.uuid4().hex[:8]
        submitted = []
        task_of = {}
        for i, task in enumerate(tasks):
            # pure=False plus a unique key: a rerun must really run, never reuse a cached result.
            fut = self._client.submit(fn, task, pure=False, key=f"scenesim-unit-{tag}-{i}")
            submitted.append(fut)
            task_of[fut.key] = task
        for fut in as_completed(submitted):
            try:
                outcome = fut.result()
            except Exception as exc:  # KilledWorker, or fn raised
                outcome = exc
            yield task_of[fut.key], outcome
            fut.release()

    def close(self) -> None:
        client = getattr(self, "_client", None)
        if client is not None:
            client.close()
        if self._cluster is not None:
            self._cluster.close()


def _forkserver_preload(modules: Sequence[str]) -> None:
    """Have the fork server Dask's nannies fork workers from import ``modules`` and Dask (whose
    own list, set on first use, is replaced: set after it).  Only before the fork server starts."""
    from distributed.utils import get_mp_context

    get_mp_context().set_forkserver_preload(["distributed", "benchmarks.run.executors", *modules])


def check_workers(workers: int | None) -> int:
    """``workers`` if it is a process count in [1, MAX_WORKERS]; None gives the CPU count."""
    if workers is None:
        return os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= MAX_WORKERS:
        raise ParameterError("workers", workers, f"a number of processes in [1, {MAX_WORKERS}]")
    return workers


def make_executor(
    executor: str = "local",
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    preload: Sequence[str] = (),
):
    """The executor called ``executor`` (``"local"`` or ``"dask"``).

    ``local`` with one worker runs in this process (:class:`SerialExecutor`).  ``scheduler``
    is only meaningful with ``dask``; ``preload`` only with a local pool or cluster.
    """
    if executor not in EXECUTORS:
        raise ParameterError("executor", executor, "one of " + ", ".join(map(repr, EXECUTORS)))
    if executor == "local":
        if scheduler:
            raise ParameterError("scheduler", scheduler, "no scheduler with the local executor (use --executor dask)")
        n = check_workers(workers)
        return SerialExecutor() if n == 1 else LocalExecutor(n, preload=preload)
    return DaskExecutor(workers, scheduler, preload=preload)
