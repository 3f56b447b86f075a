"""Sweep files: deterministic expansion, stable condition ids, errors naming key and line."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from benchmarks.run.sweep import PRESETS, Condition, load_sweep, parse_sweep
from scenesim.errors import ConfigError, ParameterError

MINIMAL = """\
[sweep]
name = "mini"

[axes]
enhancers = ["passthrough"]
noise = ["babble", "wind"]
snr_db = [0, 5]
seeds = [0, 1]

[fixed]
duration_s = 2.0
"""


def test_expansion_is_the_cartesian_product_with_snr_innermost():
    sweep = parse_sweep(MINIMAL)
    conds = sweep.conditions()
    assert len(conds) == 2 * 2 * 2
    got = [(c.noise, c.seed, c.snr_db) for c in conds]
    # noise outside seed outside SNR: a geometry group's SNRs are adjacent.
    assert got == [
        ("babble", 0, 0.0), ("babble", 0, 5.0), ("babble", 1, 0.0), ("babble", 1, 5.0),
        ("wind", 0, 0.0), ("wind", 0, 5.0), ("wind", 1, 0.0), ("wind", 1, 5.0),
    ]  # fmt: skip
    assert [c.id for c in conds] == [c.id for c in parse_sweep(MINIMAL).conditions()]
    assert len({c.id for c in conds}) == len(conds)
    # same geometry group <=> same everything but the SNR
    assert conds[0].group_id == conds[1].group_id != conds[2].group_id


def test_ids_do_not_depend_on_spelling_or_key_order():
    respelled = MINIMAL.replace("snr_db = [0, 5]", "snr_db = [0.0, 5.0]").replace(
        "[fixed]\nduration_s = 2.0", "[fixed]\nduration_s = 2\nfs = 16000"
    )
    assert [c.id for c in parse_sweep(respelled).conditions()] == [
        c.id for c in parse_sweep(MINIMAL).conditions()
    ]


def test_condition_json_round_trip():
    cond = load_sweep("reverb").conditions()[10]
    back = Condition.from_json(cond.to_json())
    assert back == cond and back.id == cond.id


def test_condition_id_is_the_same_in_another_process():
    """The id is a hash of canonical JSON, not Python's salted hash(): check across processes."""
    code = "from benchmarks.run.sweep import load_sweep; print(' '.join(c.id for c in load_sweep('thesis').conditions()))"
    runs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env={"PYTHONHASHSEED": str(s), "PATH": ""}).stdout.split()
        for s in (1, 2)
    ]
    here = [c.id for c in load_sweep("thesis").conditions()]
    assert runs[0] == runs[1] == here


def test_known_id_value():
    """Regression guard: the id of the first thesis condition must not change silently
    (changing it orphans every store on disk; bump ID_VERSION on purpose instead)."""
    first = load_sweep("thesis").conditions()[0]
    assert (first.noise, first.snr_db) == ("babble", 0.0)
    import hashlib

    assert first.id == hashlib.sha256(first.to_json().encode()).hexdigest()[:16]
    assert first.id == "e3d3d3c4fdc5a559"


@pytest.mark.parametrize(
    ("name", "n_conditions", "n_enhancers"),
    [("thesis", 18, 4), ("thesis-text", 18, 3), ("thesis-fit", 18, 3), ("phone", 120, 15), ("mismatch", 96, 4), ("peers", 45, 15), ("reverb", 80, 13),
     ("distance", 36, 10), ("angles", 24, 5),
     ("smoke", 4, 4)],
)
def test_presets_load_with_their_documented_sizes(name, n_conditions, n_enhancers):
    sweep = load_sweep(name)
    assert sweep.name == name and sweep.description
    assert len(sweep.conditions()) == n_conditions
    assert len(sweep.enhancers) == n_enhancers
    assert set(PRESETS) == {"thesis", "thesis-text", "thesis-fit", "thesis-repro", "phone", "mismatch", "peers",
                            "reverb", "distance", "angles", "smoke"}


def test_thesis_repro_is_an_alias_of_thesis_fit():
    alias, fit = load_sweep("thesis-repro"), load_sweep("thesis-fit")
    assert alias.name == "thesis-fit" and alias.conditions() == fit.conditions()
    assert alias.enhancer_params == fit.enhancer_params


def test_reverb_draws_talker_and_noise_per_seed_the_same_at_every_rt60():
    conds = load_sweep("reverb").conditions()
    by_seed = {}
    for c in conds:
        assert 20 <= c.speech_az_deg <= 70 and 0.5 <= c.distance_m <= 1.2
        assert c.noise_field == "diffuse" or 100 <= c.noise_az_deg <= 260
        by_seed.setdefault(c.seed, set()).add((c.speech_az_deg, c.distance_m))
    assert all(len(v) == 1 for v in by_seed.values())  # one placement per seed, every RT60
    assert len({next(iter(v)) for v in by_seed.values()}) == 5  # and a different one per seed
    assert {c.reference for c in conds} == {"early50"}


def test_thesis_is_the_thesis_setup_with_babble_0db_first():
    sweep = load_sweep("thesis")
    conds = sweep.conditions()
    assert set(sweep.enhancers) == {"eb", "ss", "eb-ss", "passthrough"}
    assert (conds[0].noise, conds[0].snr_db) == ("babble", 0.0)
    assert {c.noise for c in conds} == {"babble", "factory", "wind"}
    assert sorted({c.snr_db for c in conds}) == [0, 5, 10, 15, 20, 25]
    assert all(c.rt60_s == 0 and c.room_dims_m is None and c.far_field for c in conds)
    assert all(c.speech_az_deg == 45 and c.noise_az_deg == 270 and c.noise_field == "point" for c in conds)


def test_anechoic_conditions_ignore_the_room_and_are_not_duplicated():
    angles = load_sweep("angles").conditions()
    anechoic = [c for c in angles if c.rt60_s == 0]
    assert len(anechoic) == 12 and all(c.room is None for c in anechoic)
    text = MINIMAL + '\n[rooms.a]\ndims_m = [5, 4, 3]\npair_center_m = [2, 2, 1]\n[rooms.b]\ndims_m = [6, 5, 3]\npair_center_m = [2, 2, 1]\n'
    text = text.replace('seeds = [0, 1]', 'seeds = [0, 1]\nroom = ["a", "b"]\nrt60_s = [0, 0.3]')
    conds = parse_sweep(text).conditions()
    # rt60 0: one free-field copy; rt60 0.3: one per room
    assert len(conds) == 8 * 3


def test_seed_offset_and_limit_apply_to_the_seed_axis():
    sweep = parse_sweep(MINIMAL)
    shifted = sweep.with_seed(10).conditions()
    assert sorted({c.seed for c in shifted}) == [10, 11]
    assert {c.id for c in shifted}.isdisjoint({c.id for c in sweep.conditions()})
    with pytest.raises(ParameterError, match="seed"):
        sweep.with_seed(-1)


def _error_for(text: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_sweep(textwrap.dedent(text), source="bad.toml")
    return str(info.value)


def test_syntax_error_names_line_and_key():
    msg = _error_for(MINIMAL.replace("snr_db = [0, 5]", "snr_db = [0, 5"))
    # tomllib notices the unclosed array on the next line; the key is found by looking back
    assert "bad.toml" in msg and "line 7" in msg and "snr_db" in msg, msg


def test_syntax_error_on_a_key_line_names_the_key():
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", "duration_s = 2.0 oops"))
    assert "line 11" in msg and "duration_s" in msg, msg


def test_unknown_key_names_key_and_line():
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", "duration_s = 2.0\nsnr_mod = 'total'"))
    assert "line 12" in msg and "fixed.snr_mod" in msg and "unknown key" in msg, msg


def test_unknown_axis_names_key_and_line():
    msg = _error_for(MINIMAL.replace("seeds = [0, 1]", "seeds = [0, 1]\nazimuth = [0, 90]"))
    assert "line 9" in msg and "axes.azimuth" in msg, msg


def test_wrong_type_names_key_and_line():
    msg = _error_for(MINIMAL.replace("snr_db = [0, 5]", 'snr_db = [0, "five"]'))
    assert "line 7" in msg and "axes.snr_db" in msg and "'five'" in msg, msg
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", "duration_s = -2.0"))
    assert "line 11" in msg and "fixed.duration_s" in msg and "[0.25, 120] s" in msg, msg
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", 'far_field = "yes"'))
    assert "line 11" in msg and "fixed.far_field" in msg, msg


def test_bad_choice_and_scalar_axis_are_reported():
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", 'noise_field = "spherical"'))
    assert "line 11" in msg and "noise_field" in msg and "'point'" in msg, msg
    msg = _error_for(MINIMAL.replace("snr_db = [0, 5]", "snr_db = 5"))
    assert "line 7" in msg and "axes.snr_db" in msg and "list" in msg, msg


def test_unknown_enhancer_and_bad_enhancer_param_are_reported():
    msg = _error_for(MINIMAL.replace('["passthrough"]', '["passthrough", "nope"]'))
    assert "line 5" in msg and "axes.enhancers" in msg and "'nope'" in msg, msg
    msg = _error_for(MINIMAL + "\n[enhancer_params.passthrough]\nbogus = 1\n")
    assert "line 14" in msg and "enhancer_params.passthrough.bogus" in msg, msg


def test_room_problems_are_reported():
    base = MINIMAL.replace("seeds = [0, 1]", 'seeds = [0, 1]\nrt60_s = [0.3]')
    msg = _error_for(base)
    assert "rt60_s" in msg and "line 9" in msg and "room" in msg, msg
    msg = _error_for(base.replace("rt60_s = [0.3]", 'rt60_s = [0.3]\nroom = ["den"]'))
    assert "axes.room" in msg and "line 10" in msg and "den" in msg, msg
    tiny = base.replace("rt60_s = [0.3]", 'rt60_s = [0.3]\nroom = ["box"]') + (
        "\n[rooms.box]\ndims_m = [2, 2, 2]\npair_center_m = [1, 1, 1]\n"
    )
    msg = _error_for(tiny.replace("duration_s = 2.0", "duration_s = 2.0\ndistance_m = 1.5"))
    assert "fixed.distance_m" in msg and "line 14" in msg and "outside" in msg, msg
    msg = _error_for(tiny.replace("pair_center_m = [1, 1, 1]", "pair_center_m = [1, 3, 1]"))
    assert "rooms.box.pair_center_m" in msg and "line 17" in msg, msg


def test_missing_required_and_duplicates_are_reported():
    msg = _error_for(MINIMAL.replace("snr_db = [0, 5]\n", ""))
    assert "snr_db" in msg and "missing" in msg, msg
    msg = _error_for(MINIMAL.replace("duration_s = 2.0", "snr_db = 5"))
    assert "fixed.snr_db" in msg and "line 11" in msg and "both" in msg, msg
    msg = _error_for(MINIMAL.replace("snr_db = [0, 5]", "snr_db = [5, 5]"))
    assert "axes.snr_db" in msg and "repeated" in msg, msg


def test_unknown_preset_and_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="unknown preset 'thesys'"):
        load_sweep("thesys")
    with pytest.raises(ConfigError, match="cannot read"):
        load_sweep(tmp_path / "absent.toml")


def test_sweep_file_on_disk_uses_its_stem_as_default_name(tmp_path):
    path = tmp_path / "my_sweep.toml"
    path.write_text(MINIMAL.replace('name = "mini"\n', ""))
    sweep = load_sweep(path)
    assert sweep.name == "my_sweep" and sweep.text == path.read_text()


def test_early_window_default_keeps_ids_and_other_values_change_them():
    base = [c.id for c in parse_sweep(MINIMAL).conditions()]
    same = parse_sweep(MINIMAL + "early_window_ms = 50\n").conditions()
    other = parse_sweep(MINIMAL + "early_window_ms = 30\n").conditions()
    assert [c.id for c in same] == base
    assert all(c.early_window_ms == 30.0 for c in other) and not set(base) & {c.id for c in other}


def test_talker_range_outside_the_room_is_a_config_error():
    from benchmarks.run.sweep import preset_text

    text = preset_text("reverb").replace("distance_range_m = [0.5, 1.2]", "distance_range_m = [0.5, 3.5]")
    with pytest.raises(ConfigError, match="distance_m.*outside room"):
        parse_sweep(text)
