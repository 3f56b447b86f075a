"""``benchmarks.studies.calibration_jitter``'s decomposition of ``eb-robust``'s speech jitter per adapted quantity.

Oracle: :func:`benchmarks.studies.calibration_jitter.measure_condition`, which measures the jitter from the
enhancer's public replays (``Result.replay``), a path independent of the record swapping under test.
"""

from __future__ import annotations

import math

import pytest

from benchmarks.run.sweep import load_sweep
from benchmarks.studies.calibration_jitter import measure_condition, swap_jitter


@pytest.fixture(scope="module")
def condition():
    return next(c for c in load_sweep("phone").conditions() if c.noise == "wind" and c.snr_db == 15 and c.seed == 0)


def test_swap_of_everything_is_the_replayed_jitter(condition):
    """Swapping every adapted quantity is the ``s - n`` run itself: ``swap_jitter(...)["all"]`` equals the
    jitter of the two runs' replays (to 1e-6 dB), and the default ``eb-robust`` adapts all three quantities."""
    d = swap_jitter(condition, None, {})
    row = next(r for r in measure_condition(condition, None, names=("eb-robust",)) if r["system"] == "eb-robust")
    assert d["all"] == pytest.approx(row["jitter"], abs=1e-6)
    assert set(d) == {"all", "r_hat", "beta", "alpha"}


def test_a_quantity_not_adapted_is_absent_and_a_fixed_one_does_not_jitter(condition):
    """``calibrate=False``: no ``r_hat`` to swap; ``das_mix=False`` and beta frozen by its own gate everywhere (``adapt_gate_db=-60``: above the ratio's floor - 60 dB): the talker
    path is a fixed linear filter, identical in both runs (closed form: jitter -inf)."""
    d = swap_jitter(condition, None, {"calibrate": False, "das_mix": False, "adapt_gate_db": -60.0})
    assert set(d) == {"all", "beta"}
    assert d["all"] < -200 or math.isinf(d["all"])


def test_ss_floor_keeps_only_conditions_with_an_identical_front_end():
    """Hand-built rows: ``eb-robust-ss``'s jitter is kept where ``eb-robust``'s is below -100 dB in the same
    condition and the input SNR is >= 15 dB, nowhere else."""
    from benchmarks.studies.calibration_jitter import ss_floor

    def row(system, snr, seed, jitter):
        return dict(system=system, noise="wind", snr=snr, seed=seed, jitter=jitter)

    rows = [row("eb-robust", 15, 0, -300.0), row("eb-robust-ss", 15, 0, -21.0),   # kept
            row("eb-robust", 15, 1, -40.0), row("eb-robust-ss", 15, 1, -25.0),    # front end differs
            row("eb-robust", 10, 0, -300.0), row("eb-robust-ss", 10, 0, -12.0)]   # below 15 dB
    assert ss_floor(rows) == {"wind": [-21.0]}


def test_ss_parameters_reach_the_chains_ss_stage_and_ss_itself():
    """``--ss``: the parameters land on ``eb-robust-ss``'s ``ss`` stage (its ``eb`` stage keeps the given
    ``--set`` values and otherwise its defaults) and on ``ss`` run alone; without them both are the defaults."""
    from benchmarks.studies.calibration_jitter import _make
    from enhancers.core.registry import make

    ss = {"power_bins": 2, "gain_bins": 2, "gain_smooth": 0.55}
    chain = _make("eb-robust-ss", False, {"calibrate": False}, ss)
    assert chain.params.ss == make("ss", **ss).params
    assert chain.params.eb == make("eb-robust", calibrate=False).params
    assert _make("ss", False, {"calibrate": False}, ss).params == make("ss", **ss).params
    assert _make("eb-robust-ss", False).params == make("eb-robust-ss").params
    assert _make("ss", False).params == make("ss").params


def test_blind_mode_is_the_registered_blind_system():
    """``--blind`` measures ``eb-robust-blind`` / ``eb-robust-blind-ss`` (the registry's names): the same parameters
    on every stage, ``--set`` / ``--ss`` winning over them, and the same output as the script's chain on a
    mixture (exactly: one computation).  Control: ``eb-robust-ss``'s output differs."""
    import argparse

    import numpy as np

    from benchmarks.studies.calibration_jitter import TALKER_BLIND_SS, _make, _params, mode_params
    from enhancers.core.registry import make

    over, ss = mode_params(argparse.Namespace(blind=True, set=[], ss=[]))
    measured = _make("eb-robust-ss", True, over, ss)
    named = make("eb-robust-blind-ss")
    assert named.params.eb == make("eb-robust-blind").params and named.params.eb.to_dict() == \
        measured.params.eb.to_dict() and named.params.ss == measured.params.ss
    x = np.random.default_rng(3).standard_normal((2, 12000))
    y = named.process(x, 16000).output
    np.testing.assert_array_equal(y, measured.process(x, 16000).output)
    assert np.abs(y - make("eb-robust-ss").process(x, 16000).output).max() > 1e-3
    over, ss = mode_params(argparse.Namespace(blind=True, set=["frame_q_db=4"], ss=["gain_bins=1"]))
    assert _params(True, over)["frame_q_db"] == 4 and ss == {**TALKER_BLIND_SS, "gain_bins": 1}
    assert mode_params(argparse.Namespace(blind=False, set=["mu=0.02"], ss=[])) == ({"mu": 0.02}, {})


def test_first_seed_picks_seeds_past_the_presets_own(monkeypatch):
    """``--first-seed 5 --seeds 2``: the conditions of seeds 5 and 6 (phones and utterances the settings were not
    tuned on), every other axis as given; by default seeds 0 .. N-1 of the preset itself."""
    import benchmarks.studies.calibration_jitter as cj

    seen = []
    monkeypatch.setattr(cj, "measure_condition", lambda cond, *a, **k: seen.append(cond) or [])
    cj.phone_rows(None, seeds=2, snrs=[25.0], noises=["wind"], first_seed=5)
    assert sorted(c.seed for c in seen) == [5, 6] and {(c.noise, c.snr_db) for c in seen} == {("wind", 25.0)}
    seen.clear()
    cj.phone_rows(None, seeds=5, snrs=[25.0], noises=["wind"])
    assert seen == [c for c in load_sweep("phone").conditions() if c.noise == "wind" and c.snr_db == 25.0]


@pytest.mark.parametrize("argv, needle", [(["--set", "beta_model=bin"], "--set 'beta_model=bin'"),
                                          (["--ss", "gainbins"], "--ss 'gainbins'")])
def test_bad_key_json_is_one_line_not_a_traceback(argv, needle, capsys):
    """A value that is not JSON (an unquoted string) or an item without ``=`` stops with argparse's one-line
    error (exit status 2) naming the option and the item, before any condition is rendered."""
    from benchmarks.studies.calibration_jitter import main

    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert needle in err[-1] and "KEY=JSON" in err[-1] and not any("Traceback" in line for line in err)
