"""Issue 15 part 2: impossible values are refused before any work, against one table of physical
ranges (``scenesim.validate.PHYSICAL_RANGES``) that sweep files and the CLI share; errors name
the key (and TOML line) or the option typed, and state the valid range."""

from __future__ import annotations

import re

import pytest

from benchmarks.cli.main import main
from benchmarks.run.sweep import parse_sweep
from scenesim.errors import ConfigError
from scenesim.validate import PHYSICAL_RANGES, physical_range_text

HEAD = '[axes]\nenhancers = ["eb"]\nnoise = ["babble"]\nsnr_db = [0]\n[fixed]\n'  # [fixed] is line 5
ROOM = 'room = "r"\n[rooms.r]\ndims_m = [10.0, 10.0, 10.0]\npair_center_m = [5.0, 5.0, 5.0]\n'


def _sweep_error(fixed: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_sweep(HEAD + fixed, source="s.toml")
    return str(info.value)


@pytest.mark.parametrize(
    "key, value, quantity",
    [("duration_s", "1e7", "duration_s"), ("duration_s", "1e-4", "duration_s"), ("spacing_m", "1e-9", "spacing_m"),
     ("spacing_m", "100.0", "spacing_m"), ("speech_az_deg", "1e300", "azimuth_deg"),
     ("noise_az_deg", "-1e300", "azimuth_deg"), ("distance_m", "1e6", "distance_m"), ("rt60_s", "30.0", "rt60_s")],
)  # fmt: skip
def test_sweep_values_outside_the_physical_range_name_key_line_and_range(key, value, quantity):
    msg = _sweep_error(f"{key} = {value}\n")
    assert f"line 6: key 'fixed.{key}'" in msg and physical_range_text(quantity) in msg, msg


def test_sweep_axis_value_names_the_axis_and_the_range():
    with pytest.raises(ConfigError, match=r"line 4: key 'axes.snr_db'.*\[-50, 80\] dB.*1e\+300"):
        parse_sweep(HEAD.replace("snr_db = [0]", "snr_db = [0, 1e300]"), source="s.toml")


def test_cli_and_sweep_share_one_snr_range(tmp_path, capsys):
    hi = PHYSICAL_RANGES["snr_db"][1]
    assert main(["simulate", "--out", str(tmp_path / "o"), "--snr-db", str(hi + 1)]) == 2
    assert physical_range_text("snr_db") in capsys.readouterr().err
    with pytest.raises(ConfigError, match=physical_range_text("snr_db").replace("[", r"\[")):
        parse_sweep(HEAD.replace("snr_db = [0]", f"snr_db = [{hi + 1}]"))


@pytest.mark.parametrize(
    "fixed, needles",
    [("distance_m = 0.015\n", ("fixed.distance_m", "between or on the mics")),
     ("noise_distance_m = 0.02\n", ("fixed.noise_distance_m", "between or on the mics")),
     ("distance_range_m = [0.012, 2.0]\n", ("fixed.distance_range_m", "between or on the mics")),
     ("snr_band_hz = [6000, 7000]\n", ("fixed.snr_band_hz", "speech band 100-4000 Hz")),
     ("snr_band_hz = [20, 60]\n", ("fixed.snr_band_hz", "speech band")),
     ("rt60_s = 0.05\n" + ROOM, ("fixed.rt60_s", "room 'r'", "cannot have RT60 0.05 s", ">= 0.2685 s")),
     ("seed = 9223372036854775808\n", ("fixed.seed", "[0, 9223372036854775807]"))],
)  # fmt: skip
def test_impossible_combinations_are_refused_at_parse_time(fixed, needles):
    msg = _sweep_error(fixed)
    assert "line " in msg and "line ?" not in msg, msg
    for needle in needles:
        assert needle in msg, (needle, msg)


def test_a_feasible_room_and_talker_still_parse():
    sweep = parse_sweep(HEAD + "rt60_s = 0.5\ndistance_m = 0.0214\nsnr_band_hz = [300, 3400]\n" + ROOM)
    assert sweep.n_conditions == 1


def test_unknown_enhancer_version_is_refused():
    msg = str(pytest.raises(ConfigError, parse_sweep, HEAD.replace('["eb"]', '["eb@99"]'), source="s.toml").value)
    assert "line 2: key 'axes.enhancers'" in msg and "eb@99" in msg and "versions" in msg, msg


def test_seed_offset_beyond_sqlite_integers_is_refused():
    from scenesim.errors import ParameterError

    sweep = parse_sweep(HEAD + "seed = 5\n")
    with pytest.raises(ParameterError, match=r"\[0, 9223372036854775802\]"):
        sweep.with_seed(2**63 - 5)


@pytest.mark.parametrize(
    "args, option",
    [(["--speech-az", "1e300"], "--speech-az"), (["--spacing-m", "100"], "--spacing-m"),
     (["--distance-m", "0.015"], "--distance-m"), (["--duration-s", "1e7"], "--duration-s"),
     (["--fs", "10000000"], "--fs"), (["--seed", str(2**63)], "--seed"),
     (["--rt60", "30", "--room", "5", "4", "3"], "--rt60"), (["--snr-band-hz", "6000", "7000"], "--snr-band-hz"),
     (["--field", "wind", "--wind-speed-mps", "-1"], "--wind-speed-mps"),
     (["--mic-highpass-hz", "5000"], "--mic-highpass-hz")],
)  # fmt: skip
def test_simulate_refuses_with_the_option_typed(args, option, tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "o"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"scenesim: error: Parameter {option}=") and "expected" in err, err
    assert not (tmp_path / "o" / "mixture.wav").exists()


RIR = ["rir", "--dims", "4", "5", "3", "--pair-center", "2", "2.5", "1.5", "--source", "1", "1", "1"]


def test_rir_refuses_an_rt60_past_the_physical_range(tmp_path, capsys):
    assert main([*RIR, "--rt60", "30", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--rt60=30.0" in err and physical_range_text("rt60_s") in err and not (tmp_path / "o").exists()


def test_rir_warns_before_a_slow_render_like_bench_run(tmp_path, capsys, monkeypatch):
    import scenesim.room.render
    from scenesim.errors import ScenesimError

    def stop(*args, **kwargs):  # the render would take ~18 min: stop where it would start
        raise ScenesimError("render reached")

    monkeypatch.setattr(scenesim.room.render, "room_rir", stop)
    assert main([*RIR, "--rt60", "8", "--out", str(tmp_path / "o")]) == 2
    warning, error = capsys.readouterr().err.strip().splitlines()
    assert warning.startswith("scenesim: warning: RT60 8 s") and "min to render" in warning
    assert "render reached" in error
    assert main([*RIR, "--rt60", "8", "--method", "hybrid", "--out", str(tmp_path / "o")]) == 2
    assert "warning" not in capsys.readouterr().err  # the hybrid tail is fast: nothing to announce


def test_bench_seed_offset_past_sqlite_integers_names_the_option_typed(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(HEAD.replace("snr_db = [0]", "snr_db = [0]\nseeds = [0, 1]"), "utf-8")
    assert main(["bench", "run", str(path), "--out", str(tmp_path / "o"), "--seed", str(2**63 - 1)]) == 2
    err = capsys.readouterr().err
    assert f"--seed={2**63 - 1}" in err and f"[0, {2**63 - 2}]" in err and not (tmp_path / "o").exists(), err


def test_a_sweep_larger_than_the_bound_is_refused_before_expansion(tmp_path):
    from benchmarks.run.sweep import MAX_CONDITIONS, load_sweep
    from scenesim.errors import ParameterError

    with pytest.raises(ParameterError, match=r"seeds.*at most 250,000 for this sweep \(4 conditions per seed"):
        load_sweep("smoke").with_seeds(10**8)
    load_sweep("smoke").with_seeds(MAX_CONDITIONS // 4)  # the bound itself is allowed (not expanded here)
    text = ('[axes]\nenhancers = ["eb"]\nnoise = ["babble"]\nsnr_db = ' + repr([i / 100 for i in range(1001)])
            + "\nseeds = " + repr(list(range(1000))) + "\n")
    with pytest.raises(ConfigError, match=r"1,001,000 conditions; at most 1,000,000"):
        parse_sweep(text)


def test_bench_run_with_a_huge_seed_count_fails_at_once_with_one_line(tmp_path, capsys):
    from benchmarks.cli.main import main

    assert main(["bench", "run", "smoke", "--seeds", "100000000", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--seeds=100000000" in err and "\n" not in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize(("flag", "value", "expected"), [
    ("--length", "1e6", r"--length=1000000.0 is invalid: expected an RIR length in \[0.001, 60\] s"),
    ("--max-order", "100000", r"--max-order=100000 is invalid: expected an integer in \[0, 300\]"),
])
def test_rir_sizes_past_their_bound_fail_before_any_work(tmp_path, capsys, flag, value, expected):
    # Before the bounds: --length 1e6 ran for minutes towards 8 GB, --max-order 1e5 asked numpy for 298 GiB.
    argv = ["rir", "--dims", "5", "4", "3", "--source", "1", "1", "1", "--mic", "3", "3", "1.5",
            "--absorption", "0.3", flag, value, "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert re.search(expected, err) and "\n" not in err and not (tmp_path / "o").exists()


def test_image_source_rir_holds_the_same_bounds():
    import scenesim
    from scenesim.errors import ParameterError

    room = scenesim.ShoeBox(dims_m=(5, 4, 3), absorption=0.3)
    for kwargs in ({"length_s": 61.0}, {"max_order": 301}):
        with pytest.raises(ParameterError):
            scenesim.image_source_rir(room, (1, 1, 1), [(3, 3, 1.5)], fs=16000, **kwargs)
    h = scenesim.image_source_rir(room, (1, 1, 1), [(3, 3, 1.5)], fs=16000, length_s=0.05)
    assert h.shape == (1, 800)


@pytest.mark.parametrize(("extra", "expected"), [
    (["--directivity", "cardioid-family", "--directivity-p", "2"],
     r"--directivity-p=2.0 is invalid: expected values in \[0, 1\]\.$"),
    (["--directivity-p", "0.5"], r"--directivity-p=0.5 is invalid: expected only with --directivity cardioid-family"),
])
def test_rir_directivity_messages_name_the_option(tmp_path, capsys, extra, expected):
    argv = ["rir", "--dims", "5", "4", "3", "--source", "1", "1", "1", "--mic", "3", "3", "1.5",
            "--absorption", "0.3", *extra, "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    assert re.search(expected, capsys.readouterr().err.strip())
