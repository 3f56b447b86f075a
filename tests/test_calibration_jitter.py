"""``benchmarks.studies.calibration_jitter``'s decomposition of ``eb-robust``'s speech jitter per adapted quantity.

Oracle: :func:`benchmarks.studies.calibration_jitter.measure_condition`, which measures the jitter from the
enhancer's public replays (``Result.replay``), a path independent of the record swapping under test.
"""

from __future__ import annotations

import math

import pytest

from benchmarks.studies.calibration_jitter import measure_condition, swap_jitter
from benchmarks.run.sweep import load_sweep


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


def test_registered_blind_systems_are_the_settled_setting():
    """``eb-robust-blind`` and ``eb-robust-blind-ss`` (the registry's names) are what ``--frame-settled``
    measures: the same parameters on every stage, and the same output as the script's chain on a mixture
    (exactly: one computation).  Control: ``eb-robust-ss``'s output differs."""
    import numpy as np

    from benchmarks.studies.calibration_jitter import COMBINED_SS, FRAME_SETTLED, _make
    from enhancers.core.registry import make

    measured = _make("eb-robust-ss", False, FRAME_SETTLED, COMBINED_SS)
    named = make("eb-robust-blind-ss")
    fields = named.params.eb.to_dict()
    assert fields == make("eb-robust-blind").params.to_dict() == make("eb-robust", **FRAME_SETTLED).params.to_dict()
    assert named.params.ss == measured.params.ss and fields == measured.params.eb.to_dict()
    x = np.random.default_rng(3).standard_normal((2, 12000))
    y = named.process(x, 16000).output
    np.testing.assert_array_equal(y, measured.process(x, 16000).output)
    assert np.abs(y - make("eb-robust-ss").process(x, 16000).output).max() > 1e-3


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


def test_combined_setting_is_every_piece_under_the_explicit_values():
    """``--combined``: :data:`COMBINED` for ``eb-robust`` and :data:`COMBINED_SS` for the ``ss`` stage, with
    ``--set`` / ``--ss`` winning; without it only the explicit values."""
    import argparse

    from benchmarks.studies.calibration_jitter import COMBINED, COMBINED_SS, mode_params

    def args(**kw):
        base = dict(set=[], ss=[], direction=False, pooled=False, combined=False, frame=False, frame_lowsnr=False,
                    frame_delayed=False, frame_smooth=False, frame_taper=False,
                    frame_settled=False)
        return argparse.Namespace(**{**base, **kw})

    over, ss = mode_params(args(combined=True, set=["mix_alpha0=0.5", "mix_bands_hz=[500, 2000]"], ss=["gain_bins=1"]))
    assert over == {**COMBINED, "mix_alpha0": 0.5, "mix_bands_hz": (500, 2000)}
    assert ss == {**COMBINED_SS, "gain_bins": 1}
    assert mode_params(args(set=["mu=0.02"])) == ({"mu": 0.02}, {})
    from enhancers.core.registry import make

    make("eb-robust", **COMBINED)  # every field exists and is valid
    make("ss", **COMBINED_SS)


def test_frame_settings_are_combined_with_the_frame_rule():
    """``--frame`` / ``--frame-lowsnr`` / ``--frame-delayed`` / ``--frame-smooth``: :data:`FRAME` (:data:`COMBINED`
    with the frame rule and the delayed DAS weight), :data:`FRAME_LOWSNR`, :data:`FRAME_DELAYED` (that with beta
    learned late: only the beta, freeze and stand-in fields change, the rest is added) or :data:`FRAME_SMOOTH`
    (that with fields added and the SNR share's range moved) or :data:`FRAME_TAPER` (``--frame-taper``: that with
    the graded edges added and three start-up fields changed) or :data:`FRAME_SETTLED` (``--frame-settled``: that
    with the rule's first 0.13 s untrusted) for ``eb-robust``, :data:`COMBINED_SS` for the
    ``ss`` stage, ``--set`` winning; all valid ``eb-robust`` parameter sets."""
    import argparse

    from benchmarks.studies.calibration_jitter import (
        COMBINED,
        COMBINED_SS,
        FRAME,
        FRAME_DELAYED,
        FRAME_LOWSNR,
        FRAME_SETTLED,
        FRAME_SMOOTH,
        FRAME_TAPER,
        mode_params,
    )
    from enhancers.core.registry import make

    def args(**kw):
        base = dict(set=[], ss=[], direction=False, pooled=False, combined=False, frame=False, frame_lowsnr=False,
                    frame_delayed=False, frame_smooth=False, frame_taper=False,
                    frame_settled=False)
        return argparse.Namespace(**{**base, **kw})

    over, ss = mode_params(args(frame=True, set=["frame_q_db=4"]))
    assert over == {**FRAME, "frame_q_db": 4} and ss == COMBINED_SS
    assert FRAME["frame_q_db"] == 5.0 and FRAME["mix_model"] == "delayed" and FRAME["freeze_level_db"] is None
    assert {k: v for k, v in FRAME.items() if k in COMBINED and k not in ("freeze_level_db", "level_hang_s",
                                                                             "level_ahead_s", "beam_freeze")} == \
        {k: v for k, v in COMBINED.items() if k not in ("freeze_level_db", "level_hang_s", "level_ahead_s", "beam_freeze")}
    assert mode_params(args(frame_lowsnr=True))[0] == FRAME_LOWSNR
    over, ss = mode_params(args(frame_delayed=True))
    assert over == FRAME_DELAYED and ss == COMBINED_SS
    assert {k: v for k, v in FRAME_DELAYED.items() if k in FRAME_LOWSNR and k not in (
        "beta_model", "beam_freeze", "mix_fast_cells", "mix_ramp_cells")} == {k: v for k, v in FRAME_LOWSNR.items()
                                                                              if k not in ("beta_model", "beam_freeze",
                                                                                           "mix_fast_cells", "mix_ramp_cells")}
    over, ss = mode_params(args(frame_smooth=True, set=["frame_start_s=0.1"]))
    assert over == {**FRAME_SMOOTH, "frame_start_s": 0.1} and ss == COMBINED_SS
    assert {k: v for k, v in FRAME_SMOOTH.items() if k in FRAME_DELAYED and k != "frame_snr_db"} == \
        {k: v for k, v in FRAME_DELAYED.items() if k != "frame_snr_db"}  # adds fields, moves the share's range
    over, ss = mode_params(args(frame_taper=True, frame_smooth=True))  # the newer setting wins
    assert over == FRAME_TAPER and ss == COMBINED_SS
    changed = ("mix_fast_ramp_cells", "mix_alpha0", "frame_snr_frames")
    assert {k: v for k, v in FRAME_TAPER.items() if k in FRAME_SMOOTH and k not in changed} == \
        {k: v for k, v in FRAME_SMOOTH.items() if k not in changed}
    over, ss = mode_params(args(frame_settled=True, frame_taper=True))
    assert over == FRAME_SETTLED and ss == COMBINED_SS
    assert FRAME_SETTLED == {**FRAME_TAPER, "frame_start_s": 0.13} and FRAME_TAPER["frame_start_s"] == 0.05
    from enhancers.beam.presets import (  # the registered eb-robust-blind(-ss)
        EB_ROBUST_BLIND,
        EB_ROBUST_BLIND_SS,
    )

    assert EB_ROBUST_BLIND == FRAME_SETTLED and EB_ROBUST_BLIND_SS == COMBINED_SS
    for params in (FRAME, FRAME_LOWSNR, FRAME_DELAYED, FRAME_SMOOTH, FRAME_TAPER, FRAME_SETTLED):
        make("eb-robust", **params)


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
