"""``scenesim tune`` end to end (issue 30 part 2): search on dev, resume, parameter sets, test run.

The toy enhancer ``toy-peak`` scales the reference mic by ``g(p) = 1 - (p - 0.3)**2``.  G.160's
total noise level reduction of a pure gain is exactly ``20 log10 g`` dB (frame powers all scale
by ``g**2``, so their log-mean shifts by ``20 log10 g``: checked below to 1e-9 dB), so the
objective ``mean:g160_tnlr_exact_db`` peaks at ``p = 0.3`` in closed form.  Sweeps are one 4-s
condition (G.160 needs P.56 pauses longer than its 0.2 s hangover, which 1 s lacks), run in this process (``--workers 1``: the toy is registered here only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

pytest.importorskip("optuna")

from benchmarks.cli.main import main  # noqa: E402
from benchmarks.tune import ParameterSet, load_parameter_set, register_tuned, save_parameter_set  # noqa: E402
from enhancers.core.base import Enhancer, Params, Result, Tags  # noqa: E402
from enhancers.core.registry import get_spec, make, register, unregister  # noqa: E402
from scenesim.validate import check_finite_number, check_signal  # noqa: E402

PEAK = 0.3

SWEEP = """
[sweep]
name = "tune-tiny"
{split}
[axes]
enhancers = ["passthrough"]
noise = ["wind"]
snr_db = [10]
seeds = [0]
[fixed]
fs = 16000
duration_s = 4.0
rt60_s = 0.0
speech_az_deg = 45
noise_az_deg = 270
noise_field = "point"
far_field = true
"""


class Peak(Enhancer):
    name = "toy-peak"
    version = "1"
    summary = "Scales its one channel by 1 - (p - 0.3)^2"

    @dataclass(frozen=True)
    class Params(Params):
        p: float = 0.5
        n: int = 1

        def __post_init__(self):
            check_finite_number("p", self.p)
            if not 0.0 <= self.p <= 1.0:
                from scenesim.errors import ParameterError

                raise ParameterError("p", self.p, "a value in [0, 1]")

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1)

    def _process(self, x, fs):
        g = 1.0 - (self.params.p - PEAK) ** 2
        return Result(output=g * x, _replay=lambda c: g * check_signal(c, name="component", n_channels=1, min_samples=0))


@pytest.fixture(autouse=True)
def toy_peak():
    register("toy-peak", Peak)
    yield
    unregister("toy-peak")
    for name in ("toy-peak-tuned",):
        try:
            unregister(name)
        except KeyError:
            pass


def _sweep(tmp_path, split=""):
    path = tmp_path / f"tiny{split}.toml"
    path.write_text(SWEEP.format(split=f'split = "{split}"' if split else ""))
    return str(path)


def _args(sweep, out, trials, *extra):
    return ["tune", "toy-peak", "--sweep", sweep, "--param", "p=0:1", "--objective", "mean:g160_tnlr_exact_db",
            "--trials", str(trials), "--out", str(out), "--workers", "1", *extra]


def _completed(out):
    import optuna

    study = optuna.load_study(study_name="scenesim-tune-toy-peak", storage=f"sqlite:///{out / 'optuna.db'}")
    return [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]


def test_the_toy_objective_is_20_log10_of_the_gain(tmp_path):
    """The oracle of the end-to-end test: tnlr(p) = 20 log10(1 - (p - 0.3)^2), to 1e-9 dB."""
    from benchmarks.run.sweep import load_sweep
    from benchmarks.tune.objective import Objective
    from benchmarks.tune.trials import SweepEvaluation

    ev = SweepEvaluation(load_sweep(_sweep(tmp_path)), "toy-peak", Objective.parse("mean:g160_tnlr_exact_db"), (),
                         tmp_path / "o", workers=1)
    for p in (0.3, 0.8):
        assert ev({"p": p}).value == pytest.approx(20 * math.log10(1 - (p - PEAK) ** 2), abs=1e-9)


def test_toy_peak_found_within_2_percent_in_50_trials(tmp_path, capsys):
    """TPE (seed 0) finds the closed-form optimum p = 0.3 to 2 % of the range [0, 1]; the chosen
    parameters then run once on test with seeds after the dev seeds."""
    out = tmp_path / "tune"
    assert main(_args(_sweep(tmp_path), out, 50, "--seeds", "1")) == 0
    captured = capsys.readouterr()
    assert captured.err.count("tune toy-peak: trial ") == 50
    ps = load_parameter_set(out / "params.toml")
    assert abs(ps.params["p"] - PEAK) <= 0.02 * (1.0 - 0.0)
    prov = ps.provenance
    assert prov["split"] == "dev" and prov["seeds"] == [0] and prov["test_seeds"] == [1]
    assert prov["test_evaluations"] == 1 and prov["trials"] == 50 and prov["data"] == "built-in"
    assert set(prov["versions"]) == {"scenesim", "numpy", "optuna"}
    assert "optimism" in (out / "tune_report.md").read_text() and (out / "tune_report.csv").is_file()
    from benchmarks.store.sqlite import ResultStore

    with ResultStore.open(out / "test", readonly=True) as store:
        rows = store.rows()
    assert {r["seed"] for r in rows} == {1} and {r.get("split") for r in rows} == {"test"}


def test_a_test_sweep_is_refused(tmp_path, capsys):
    assert main(_args(_sweep(tmp_path, "test"), tmp_path / "o", 2)) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'split = "test"' in err and "dev material only" in err
    assert not (tmp_path / "o" / "trials").exists()


def test_an_all_sweep_runs_as_dev(tmp_path):
    from benchmarks.store.sqlite import ResultStore

    assert main(_args(_sweep(tmp_path, "all"), tmp_path / "o", 1, "--no-test")) == 0
    (store_dir,) = (tmp_path / "o" / "trials").iterdir()
    with ResultStore.open(store_dir, readonly=True) as store:
        assert {r.get("split") for r in store.rows()} == {"dev"}


def test_ctrl_c_resumes_to_the_total_without_rerunning_finished_trials(tmp_path, monkeypatch):
    """Interrupted in trial 4 (KeyboardInterrupt from inside the evaluation), a rerun continues
    to 6 finished trials in total, evaluates the cut trial's parameters first and reruns none."""
    from benchmarks.tune import trials as trials_mod

    calls = []
    real = trials_mod.SweepEvaluation.__call__

    def counting(self, params):
        calls.append(dict(params))
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(self, params)

    monkeypatch.setattr(trials_mod.SweepEvaluation, "__call__", counting)
    out = tmp_path / "o"
    assert main(_args(_sweep(tmp_path), out, 6, "--no-test")) == 130
    first = {t.number: t.params for t in _completed(out)}
    assert len(first) == 3
    cut = calls[3]
    assert main(_args(_sweep(tmp_path), out, 6, "--no-test")) == 0
    done = _completed(out)
    assert len(done) == 6 and len(calls) == 4 + 3
    assert calls[4] == cut  # the interrupted trial's parameters come first
    assert {t.number: t.params for t in done if t.number in first} == first


def test_a_rerun_of_a_finished_study_runs_no_trial_and_counts_the_second_look_at_test(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(_args(_sweep(tmp_path), out, 2)) == 0
    assert load_parameter_set(out / "params.toml").provenance["test_evaluations"] == 1
    capsys.readouterr()
    assert main(_args(_sweep(tmp_path), out, 2)) == 0
    err = capsys.readouterr().err
    assert "trial " not in err.replace("trials (2 done)", "")
    assert "test has been looked at 2 times" in err
    assert load_parameter_set(out / "params.toml").provenance["test_evaluations"] == 2


def test_a_study_of_another_configuration_is_refused(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(_args(_sweep(tmp_path), out, 1, "--no-test")) == 0
    capsys.readouterr()
    args = _args(_sweep(tmp_path), out, 1, "--no-test")
    args[args.index("p=0:1")] = "p=0:0.5"
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "search_space" in err and "another configuration" in err


def test_parameter_set_round_trips_and_registers_with_its_provenance(tmp_path):
    prov = {"objective": "mean:snr_i_db", "seeds": [0, 1, 2], "split": "dev", "feasible": True,
            "best_value": -0.125, "worst": -math.inf, "test_evaluations": 3,
            "versions": {"scenesim": "1.0", "numpy": "2.4.6", "optuna": "5.1.0"}, "note": 'a "quoted" é'}
    ps = ParameterSet("toy-peak-tuned", "toy-peak", {"p": 0.3125, "n": 4}, prov)
    path = save_parameter_set(tmp_path / "params.toml", ps)
    assert load_parameter_set(path) == ps
    register_tuned("toy-peak-tuned", path)
    assert make("toy-peak-tuned").params.p == 0.3125
    assert get_spec("toy-peak-tuned").provenance["seeds"] == [0, 1, 2]


def test_a_none_choice_round_trips(tmp_path):
    ps = ParameterSet("x", "toy-peak", {"p": None}, {})
    assert load_parameter_set(save_parameter_set(tmp_path / "p.toml", ps)).params == {"p": None}


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("p0:1", "NAME=LO:HI"),
        ("q=0:1", "a field of toy-peak's Params: n, p"),
        ("p=0.9:0.1", "LO <= HI"),
        ("p=0:1:lin", "NAME=LO:HI"),
        ("p=0:1:log", "LO > 0"),
        ("p=0:2", "values the enhancer accepts"),
        ("n=1.5:3", "int bounds"),
        ("p=0.1,,0.2", "without empty choices"),
    ],
)
def test_bad_param_is_one_line_naming_what_was_typed(tmp_path, capsys, spec, says):
    args = _args(_sweep(tmp_path), tmp_path / "o", 1)
    args[args.index("p=0:1")] = spec
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and repr(spec) in err and says in err, err


@pytest.mark.parametrize(
    ("option", "value", "says"),
    [("--objective", "avg:snr_i_db", "AGG:COLUMN"), ("--objective", "mean:snr", "numeric results column"),
     ("--constraint", "speech_jitter_db<-30", "COLUMN<=VALUE"), ("--constraint", "x<=1@snr_in_db>=15", "numeric")],
)
def test_bad_objective_or_constraint_is_one_line(tmp_path, capsys, option, value, says):
    assert main([*_args(_sweep(tmp_path), tmp_path / "o", 1), option, value]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and repr(value) in err and says in err, err


def test_constraint_value_is_the_worst_violation_and_steers_the_choice(tmp_path):
    """With g160_dsn_db >= -0.5 (a gain of at least 10^(-0.5/20)), every kept trial meets it;
    the constraint's value is max over rows of (bound - value), in dB."""
    out = tmp_path / "o"
    assert main([*_args(_sweep(tmp_path), out, 12, "--no-test"), "--constraint", "g160_dsn_db>=-0.5"]) == 0
    ps = load_parameter_set(out / "params.toml")
    g = 1 - (ps.params["p"] - PEAK) ** 2
    assert ps.provenance["feasible"] and 20 * np.log10(g) >= -0.5
    for t in _completed(out):
        g = 1 - (t.params["p"] - PEAK) ** 2
        assert t.user_attrs["constraints"][0] == pytest.approx(-0.5 - 20 * math.log10(g), abs=1e-9)
        if hasattr(t, "constraints"):  # Optuna >= 5: what Trial.set_constraint gave the sampler
            assert list(t.constraints.values()) == t.user_attrs["constraints"]


def test_without_optuna_the_command_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "optuna", None)  # import optuna raises ImportError
    assert main(_args(_sweep(tmp_path), tmp_path / "o", 1)) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'pip install "scenesim[tune]"' in err
