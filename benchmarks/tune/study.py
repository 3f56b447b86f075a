"""The Optuna loop of ``scenesim tune``: a seeded TPE search, resumable, one progress line a trial.

:func:`optimize` runs any ``evaluate(params) -> Evaluation``; the CLI's evaluates a sweep on
``dev`` material (:class:`benchmarks.tune.trials.SweepEvaluation`).  It uses Optuna's documented API only: ``optuna.create_study`` with its SQLite storage
``DIR/optuna.db`` and ``load_if_exists=True``, ``TPESampler(seed=...)``, constraints through
``Trial.set_constraint`` (Optuna >= 5; ``constraints_func`` on Optuna 4) and
``study.ask`` / ``study.tell``.  Resuming: a second call on the same ``DIR`` continues to
``trials`` finished trials in total; finished trials are never rerun, and a trial cut by Ctrl-C
is marked failed (``user_attrs['interrupted']``) and its parameters are enqueued, so the next
call evaluates them first (its per-trial store resumes where it stopped).  The study opens in
optuna-dashboard: ``optuna-dashboard sqlite:///DIR/optuna.db``.
"""

from __future__ import annotations

import json
import math
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenesim.errors import ConfigError, PluginError

STORAGE_NAME = "optuna.db"
INSTALL_HINT = 'scenesim tune needs Optuna: pip install "scenesim[tune]"'
_BIG = 1e12  # stands in for an infinite constraint value (Optuna wants finite numbers)


def require_optuna():
    """The ``optuna`` module, or a one-line :class:`PluginError` saying how to install it."""
    try:
        import optuna
    except ImportError:
        raise PluginError(INSTALL_HINT) from None
    return optuna


@dataclass(frozen=True)
class Evaluation:
    """One trial's outcome: ``value`` (None: the trial failed, ``reason`` says why) and the
    constraint values (feasible when every one is <= 0)."""

    value: float | None
    constraints: tuple[float, ...] = ()
    attrs: Mapping[str, Any] = field(default_factory=dict)
    reason: str | None = None
    constraint_names: tuple[str, ...] = ()


class TuneInterrupted(KeyboardInterrupt):
    """Ctrl-C during a tuning run; ``str()`` says how many trials are kept and how to resume."""

    def __init__(self, n_done: int, n_total: int, out_dir):
        super().__init__(n_done, n_total, str(out_dir))
        self.n_done, self.n_total, self.out_dir = n_done, n_total, Path(out_dir)

    def __str__(self) -> str:
        return (f"interrupted: {self.n_done} of {self.n_total} trials kept in {self.out_dir / STORAGE_NAME}; "
                "rerun the same command to continue")


def storage_url(out_dir: str | Path) -> str:
    """The study's SQLite storage URL inside ``out_dir`` (what optuna-dashboard opens)."""
    return f"sqlite:///{Path(out_dir).resolve() / STORAGE_NAME}"


def _has_set_constraint(optuna) -> bool:
    return hasattr(optuna.trial.Trial, "set_constraint")


def _constraints_of(trial) -> Sequence[float]:
    return trial.user_attrs.get("constraints", ())


def open_study(out_dir: str | Path, *, name: str, direction: str, seed: int, constrained: bool,
               config: Mapping[str, Any]):
    """Create or load the study ``name`` in ``out_dir/optuna.db``; refuse one of another ``config``."""
    optuna = require_optuna()
    # Optuna >= 5 reads constraints a trial set with Trial.set_constraint (constraints_func is
    # deprecated there); Optuna 4 has only constraints_func, which is marked experimental.
    legacy = constrained and not _has_set_constraint(optuna)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        sampler = optuna.samplers.TPESampler(seed=seed, constraints_func=_constraints_of if legacy else None)
    study = optuna.create_study(study_name=name, storage=storage_url(out_dir), load_if_exists=True,
                                sampler=sampler, direction=direction)
    stored = study.user_attrs.get("config")
    wanted = json.loads(json.dumps(dict(config)))
    if stored is None:
        study.set_user_attr("config", wanted)
    elif stored != wanted:
        diff = sorted(k for k in set(stored) | set(wanted) if stored.get(k) != wanted.get(k))
        raise ConfigError(f"{out_dir} holds a study of another configuration ({', '.join(diff)} differ); "
                          "use a new --out directory or the same options")
    return study


def counted(study) -> list:
    """The trials that count towards the total: finished, and not cut short by Ctrl-C."""
    optuna = require_optuna()
    done = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL)
    return [t for t in study.get_trials(deepcopy=False) if t.state in done and not t.user_attrs.get("interrupted")]


def optimize(study, evaluate: Callable[[dict], Evaluation], dims, *, trials: int, out_dir,
             log: Callable[[str], None] | None = None, label: str = "tune") -> None:
    """Ask/tell ``study`` until ``trials`` trials count (:func:`counted`); one ``log`` line each."""
    log = log or _stderr
    distributions = {d.name: d.distribution() for d in dims}
    n_done = len(counted(study))
    while n_done < trials:
        trial = study.ask(distributions)
        t0 = time.perf_counter()
        try:
            result = evaluate(dict(trial.params))
        except KeyboardInterrupt:
            trial.set_user_attr("interrupted", True)
            study.tell(trial, state=require_optuna().trial.TrialState.FAIL)
            study.enqueue_trial(dict(trial.params))  # the next call evaluates these first
            raise TuneInterrupted(n_done, trials, out_dir) from None
        _tell(study, trial, result)
        n_done += 1
        log(progress_line(study, trial.number, dict(trial.params), result, n_done=n_done, trials=trials,
                          seconds=time.perf_counter() - t0, label=label))


def _tell(study, trial, result: Evaluation) -> None:
    optuna = require_optuna()
    for key, value in result.attrs.items():
        trial.set_user_attr(key, value)
    finite = [c if math.isfinite(c) else math.copysign(_BIG, c) for c in result.constraints]
    trial.set_user_attr("constraints", finite)
    if _has_set_constraint(optuna):
        for i, (text, value) in enumerate(zip(result.constraint_names, finite)):
            trial.set_constraint(text or f"constraint{i}", value)
    if result.value is None or not math.isfinite(result.value):
        trial.set_user_attr("fail_reason", result.reason or f"objective {result.value}")
        study.tell(trial, state=optuna.trial.TrialState.FAIL)
    else:
        study.tell(trial, result.value)


def feasible(trial) -> bool:
    return all(c <= 0 for c in _constraints_of(trial))


def best_trial(study):
    """The best complete trial among the feasible ones (Optuna's ``best_trial`` ignores
    constraints); with none feasible, the one of least total violation.  None: no trial completed."""
    optuna = require_optuna()
    done = [t for t in study.get_trials(deepcopy=False) if t.state == optuna.trial.TrialState.COMPLETE]
    if not done:
        return None
    ok = [t for t in done if feasible(t)]
    if not ok:
        return min(done, key=lambda t: (sum(max(c, 0.0) for c in _constraints_of(t)), t.number))
    sign = -1.0 if study.direction == optuna.study.StudyDirection.MAXIMIZE else 1.0
    return min(ok, key=lambda t: (sign * t.value, t.number))


def progress_line(study, number: int, params: Mapping[str, Any], result: Evaluation, *, n_done: int, trials: int, seconds: float,
                  label: str = "tune") -> str:
    """``tune NAME: trial k/N (#id) value V | best B (#id) | params | s``."""
    if result.value is None:
        value = f"failed ({result.reason})"
    else:
        value = f"{result.value:.5g}" + ("" if all(c <= 0 for c in result.constraints)
                                         else f" infeasible (worst violation {max(result.constraints):.3g})")
    best = best_trial(study)
    best_text = "none yet" if best is None else f"{best.value:.5g} (#{best.number}{'' if feasible(best) else ', infeasible'})"
    shown = " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in params.items())
    return f"{label}: trial {n_done}/{trials} (#{number}) value {value} | best {best_text} | {shown} | {seconds:.1f} s"


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
