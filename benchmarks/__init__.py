"""Benchmark suite: conditions and sweeps, metrics, runner and executors, results store, report, CLI."""

__all__ = ["load_results"]


def __getattr__(name: str):
    # Lazy (PEP 562): ``import benchmarks`` stays cheap for the CLI and the workers, while
    # ``benchmarks.load_results`` pulls in the store (and its metrics columns) on first use.
    if name == "load_results":
        from benchmarks.store.frame import load_results

        return load_results
    raise AttributeError(f"module 'benchmarks' has no attribute {name!r}")
