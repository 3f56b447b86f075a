"""One tuning trial on a sweep: the sweep narrowed to the tuned enhancer, run on ``dev`` material.

:class:`SweepEvaluation` is the ``evaluate(params)`` that :func:`benchmarks.tune.study.optimize`
calls for ``scenesim tune``: it runs the sweep, restricted to the enhancer with the trial's
parameters over the sweep's own ``[enhancer_params]``, through the project's runner
(:func:`benchmarks.run.runner.run_sweep`) into a store of its own, ``DIR/trials/<key>``, keyed
by a hash of the parameters (the same parameters reuse, or resume, the same store), then reads
the store's rows to compute the objective and the constraints.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.run.sweep import Sweep
from benchmarks.tune.objective import Constraint, Objective
from benchmarks.tune.study import Evaluation
from scenesim.errors import ConfigError

TRIALS_DIR = "trials"


def split_of(sweep: Sweep) -> str:
    """The sweep's ``split`` ('dev', 'test' or 'all'; 'all' where this checkout has no splits)."""
    return getattr(sweep, "split", "all")


def splits_supported(sweep: Sweep) -> bool:
    """True when sweeps carry a ``split`` (dev/test material); else only the seeds separate them."""
    return hasattr(sweep, "split")


def with_split(sweep: Sweep, split: str) -> Sweep:
    """``sweep`` drawing only ``split``'s material (unchanged where splits do not exist)."""
    helper = getattr(sweep, "with_split", None)
    if callable(helper):
        return helper(split)
    return dataclasses.replace(sweep, split=split) if splits_supported(sweep) else sweep


def dev_sweep(sweep: Sweep) -> Sweep:
    """The sweep a search may evaluate: its ``dev`` part; a ``test`` sweep is refused."""
    if split_of(sweep) == "test":
        raise ConfigError(
            f"sweep {sweep.name!r} has split = \"test\": scenesim tune searches dev material only "
            "(give a \"dev\" or \"all\" sweep; the chosen parameters are run on test once, after the search)"
        )
    return with_split(sweep, "dev")


def restrict(sweep: Sweep, enhancer: str, params: Mapping[str, Any]) -> Sweep:
    """``sweep`` with ``enhancer`` alone, its parameters ``params`` over the sweep's own."""
    merged = {**sweep.enhancer_params.get(enhancer, {}), **params}
    return dataclasses.replace(sweep, enhancers=(enhancer,), enhancer_params={enhancer: merged})


def params_key(params: Mapping[str, Any]) -> str:
    """A short stable hash of a parameter set (the name of its trial store).

    >>> params_key({"b": 1, "a": 0.5}) == params_key({"a": 0.5, "b": 1})
    True
    """
    return hashlib.sha256(json.dumps(dict(params), sort_keys=True).encode()).hexdigest()[:16]


def seeds_of(conditions: Sequence[Any]) -> list[int]:
    """The distinct seeds of ``conditions``, ascending."""
    return sorted({int(c.seed) for c in conditions})


def test_sweep(dev: Sweep, dev_seeds: Sequence[int], n_seeds: int) -> Sweep:
    """``dev``'s ``test`` counterpart on ``n_seeds`` seeds after the last dev seed (disjoint).

    >>> from benchmarks.run.sweep import load_sweep
    >>> test_sweep(load_sweep("smoke").with_seeds(3), [0, 1, 2], 2).conditions()[0].seed
    3
    """
    fresh = dataclasses.replace(with_split(dev, "test").with_seeds(n_seeds), seed_offset=0)
    return fresh.with_seed(max(dev_seeds) + 1)


class SweepEvaluation:
    """``evaluate(params) -> Evaluation`` for one enhancer on a (dev) sweep.

    Parameters
    ----------
    sweep : Sweep
        The sweep with its seeds already chosen (``with_seeds``/``with_seed``) and split applied.
    enhancer : str
        Registry name of the tuned enhancer.
    objective, constraints
        What each trial is scored by (:mod:`benchmarks.tune.objective`).
    out_dir : path
        The tuning directory; trial stores go under ``out_dir/trials``.
    data_dir, limit, workers
        As for ``scenesim bench run``.
    log : callable
        Receives each distinct warning once (the runner's, per trial, would repeat).
    """

    def __init__(self, sweep: Sweep, enhancer: str, objective: Objective, constraints: Sequence[Constraint],
                 out_dir, *, data_dir=None, limit: int | None = None, workers: int | None = None,
                 log: Callable[[str], None] = print):
        self.sweep, self.enhancer, self.objective = sweep, enhancer, objective
        self.constraints = tuple(constraints)
        self.out_dir = Path(out_dir)
        self.data_dir, self.limit, self.workers, self.log = data_dir, limit, workers, log
        self._seen: set[str] = set()

    def rows(self, params: Mapping[str, Any], *, sweep: Sweep | None = None, where: Path | None = None) -> list[dict]:
        """Run ``params`` on ``sweep`` (default: the dev sweep) into ``where`` and return its rows."""
        from benchmarks.run.runner import _select_conditions, run_sweep
        from benchmarks.store.sqlite import ResultStore

        sweep = restrict(sweep or self.sweep, self.enhancer, params)
        where = where or self.out_dir / TRIALS_DIR / params_key(params)
        n = len(_select_conditions(sweep, seed=None, limit=self.limit)[1])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            summary = run_sweep(sweep, where, workers=self.workers or min(n, os.cpu_count() or 1),
                                data_dir=self.data_dir, limit=self.limit, report=None, progress=False,
                                listen_count=0)
        self._say([str(w.message) for w in caught] + list(summary.warnings))
        with ResultStore.open(where, readonly=True) as store:
            return store.rows("enhancer = ?", (self.enhancer,))

    def _say(self, notes: Sequence[str]) -> None:
        for note in notes:
            if note not in self._seen:
                self._seen.add(note)
                self.log(f"scenesim: warning: {note}")

    def score(self, rows: Sequence[Mapping[str, Any]]) -> Evaluation:
        """The objective and constraint values of ``rows``."""
        n_ok = sum(r.get("status") == "ok" for r in rows)
        value = self.objective.value(rows)
        first_error = next((r.get("error") for r in rows if r.get("status") != "ok"), None)
        reason = None if value is not None else (
            f"no ok row with a value in {self.objective.column} ({len(rows) - n_ok} of {len(rows)} rows failed"
            + (f"; first error: {first_error})" if first_error else ")"))
        return Evaluation(value, tuple(c.value(rows) for c in self.constraints),
                          {"n_rows": len(rows), "n_ok": n_ok}, reason, tuple(c.text for c in self.constraints))

    def __call__(self, params: Mapping[str, Any]) -> Evaluation:
        rows = self.rows(params)
        result = self.score(rows)
        return dataclasses.replace(result, attrs={**result.attrs, "store": f"{TRIALS_DIR}/{params_key(params)}"})
