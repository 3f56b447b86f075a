"""Benchmark suite: conditions and sweeps, metrics, runner and executors, results store, report, CLI."""
