"""One local ``scenesim bench run smoke`` per test session, shared by the CLI and Dask tests."""

from __future__ import annotations

from pathlib import Path

from benchmarks.cli.main import main

_RUN: dict[str, tuple[int, Path]] = {}


def local_smoke_run(tmp_path_factory) -> tuple[int, Path]:
    """``(exit code, out dir)`` of ``scenesim bench run smoke --workers 1`` (run once per session).

    One worker runs in this process: no pool start-up, so the run takes seconds.
    """
    if "smoke" not in _RUN:
        out = tmp_path_factory.mktemp("smoke")
        code = main(["bench", "run", "smoke", "--out", str(out), "--workers", "1"])
        _RUN["smoke"] = (code, out)
    return _RUN["smoke"]
