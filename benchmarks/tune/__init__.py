"""Tuning an enhancer's parameters on ``dev`` material and measuring the result on ``test``.

``scenesim tune`` (:mod:`benchmarks.cli.tune`) is :func:`tune`: a seeded Optuna TPE search
(:mod:`.study`) over ``--param`` ranges of the enhancer's ``Params`` (:mod:`.space`), each trial
a run of the sweep's dev part through the project's runner (:mod:`.trials`), scored by an
objective and constraints over store columns (:mod:`.objective`); the best parameters go to a
named parameter set with its provenance (:mod:`.paramset`) and are run once on test with other
seeds, the report giving the optimism dev - test (:mod:`.holdout`).

Using a result::

    from benchmarks.tune import load_parameter_set, register_tuned
    ps = load_parameter_set("out/params.toml")       # ps.enhancer, ps.params, ps.provenance
    e = enhancers.make(ps.enhancer, **ps.params)      # the tuned system
    register_tuned("eb-robust-tuned", "out/params.toml")   # or under a name, provenance attached
"""

from benchmarks.tune.paramset import (
           ParameterSet,
           load_parameter_set,
           register_tuned,
           save_parameter_set,
)
from benchmarks.tune.tuner import TuneOutcome, TuneSettings, tune

__all__ = ["ParameterSet", "TuneOutcome", "TuneSettings", "load_parameter_set", "register_tuned",
           "save_parameter_set", "tune"]
