"""Bad command-line inputs end in one ``scenesim: error:`` line and exit 2, never a traceback.

Regression tests for issue 11 (a new user's 112 bad inputs): each test names the input
that used to give a traceback or a silently wrong result.  Commands run through
``benchmarks.cli.main.main`` with capsys, like the other test_cli_* files, except the
console-script checks (``--version``, warning format), which run the installed script.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main

FS = 16000
PROC = Path("/proc")
needs_proc = pytest.mark.skipif(not PROC.is_dir(), reason="needs Linux /proc (an uncreatable path)")
RIR_ROOM = ["rir", "--dims", "4", "5", "3", "--rt60", "0.3"]
PAIR = ["--pair-center", "2", "2.5", "1.5"]


def _one_error_line(capsys, *needles: str) -> str:
    """The captured stderr is exactly one ``scenesim: error:`` line containing every needle."""
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("scenesim: error:"), err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


@pytest.fixture
def a_file(tmp_path) -> Path:
    path = tmp_path / "afile"
    path.write_text("not a directory")
    return path


@pytest.fixture
def stereo_wav(tmp_path, rng) -> Path:
    path = tmp_path / "in.wav"
    sf.write(path, 0.1 * rng.standard_normal((FS // 4, 2)), FS, subtype="FLOAT")
    return path


def _out_commands(tmp_path, wav):
    """Each command with a directory output, as a function of that output."""
    return {
        "simulate": lambda out: ["simulate", "--duration-s", "0.25", "--out", out],
        "rir": lambda out: [*RIR_ROOM, *PAIR, "--source", "1", "1", "1", "--out", out],
        "bench run": lambda out: ["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--out", out],
        "data prepare": lambda out: ["data", "prepare", "artificial-voice", "--dest", out],
    }


@pytest.mark.parametrize("command", ["simulate", "rir", "bench run", "data prepare"])
@pytest.mark.parametrize("kind", ["existing file", "empty", "uncreatable"])
def test_unusable_output_directory_is_one_line_error(command, kind, tmp_path, a_file, stereo_wav, capsys):
    if kind == "uncreatable" and not PROC.is_dir():
        pytest.skip("needs /proc")
    out = {"existing file": str(a_file), "empty": "", "uncreatable": "/proc/scenesim-x"}[kind]
    argv = _out_commands(tmp_path, stereo_wav)[command](out)
    assert main(argv) == 2
    option = "--dest" if command == "data prepare" else "--out"
    _one_error_line(capsys, option, {"existing file": "existing file", "empty": "not empty",
                                     "uncreatable": "choose another"}[kind])
    assert a_file.read_text() == "not a directory"


@pytest.mark.parametrize("kind", ["existing dir", "empty", "uncreatable"])
def test_unusable_enhance_output_file_is_one_line_error(kind, tmp_path, stereo_wav, capsys):
    if kind == "uncreatable" and not PROC.is_dir():
        pytest.skip("needs /proc")
    out = {"existing dir": str(tmp_path), "empty": "", "uncreatable": "/proc/scenesim-x.wav"}[kind]
    assert main(["enhance", str(stereo_wav), out, "-e", "passthrough"]) == 2
    _one_error_line(capsys, "OUT")


@needs_proc
def test_unwritable_enhance_trace_is_an_error_before_any_work(tmp_path, stereo_wav, capsys):
    out = tmp_path / "o.wav"
    assert main(["enhance", str(stereo_wav), str(out), "-e", "eb", "--trace", "/proc/t.npz"]) == 2
    _one_error_line(capsys, "--trace")
    assert not out.exists()


def _truncated_store(path: Path) -> None:
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE t (x TEXT)")
    db.executemany("INSERT INTO t VALUES (?)", [("x" * 100,)] * 2000)
    db.commit()
    db.close()
    with open(path, "r+b") as fh:
        fh.truncate(3000)


def _garbage_store(path: Path) -> None:
    path.write_bytes(b"this is not sqlite at all" * 100)


def _undecodable_store(path: Path) -> None:
    from benchmarks.store.sqlite import ResultStore

    with ResultStore(path) as store:
        # Bytes that are not UTF-8 in a text column every command reads (the condition id).
        store._db.execute(
            "INSERT INTO results (condition_id, enhancer, status) VALUES (CAST(X'FFFE80' AS TEXT), 'eb', 'ok')"
        )
        store._db.commit()


@pytest.mark.parametrize("damage", [_truncated_store, _garbage_store, _undecodable_store])
@pytest.mark.parametrize("action", ["run", "report"])
def test_corrupt_store_says_so_and_is_not_overwritten(damage, action, tmp_path, capsys):
    store = tmp_path / "results.sqlite"
    damage(store)
    before = store.read_bytes()
    argv = (["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--out", str(tmp_path)]
            if action == "run" else ["bench", "report", str(tmp_path)])
    assert main(argv) == 2
    _one_error_line(capsys, "corrupt", f"mv {store} {store}.corrupt")
    assert store.read_bytes() == before
    assert not (tmp_path / "report").exists()


def test_source_on_a_mic_is_an_error_not_a_nan_rir(tmp_path, capsys):
    for offset_m in (0.0, 0.0005):  # on the mic, and within 1 mm of it
        out = tmp_path / f"r{offset_m}"
        argv = [*RIR_ROOM, "--source", "2", "2.5", str(1.5 + offset_m), "--mic", "2", "2.5", "1.5",
                "--out", str(out)]
        assert main(argv) == 2
        _one_error_line(capsys, "--source", "at least 1 mm from every mic")  # the renderer's rule
        assert not (out / "rir.npy").exists()


@pytest.mark.parametrize("fs", ["1", "100", "4000"])
@pytest.mark.parametrize("command", ["simulate", "rir", "enhance"])
def test_sampling_rate_below_the_minimum_is_a_parameter_error(command, fs, tmp_path, stereo_wav, capsys):
    argv = {
        "simulate": ["simulate", "--duration-s", "0.25", "--out", str(tmp_path / "s")],
        "rir": [*RIR_ROOM, *PAIR, "--source", "1", "1", "1", "--out", str(tmp_path / "r")],
        "enhance": ["enhance", str(stereo_wav), str(tmp_path / "o.wav"), "-e", "passthrough"],
    }[command]
    assert main([*argv, "--fs", fs]) == 2
    _one_error_line(capsys, f"--fs={fs}", ">= 8000 Hz")


@pytest.mark.parametrize("snr", ["200", "-100", "80.5", "-50.5"])
def test_snr_outside_a_sane_range_is_rejected(snr, tmp_path, capsys):
    assert main(["simulate", "--duration-s", "0.25", "--snr-db", snr, "--out", str(tmp_path)]) == 2
    _one_error_line(capsys, "--snr-db", "[-50, 80] dB")


def test_snr_at_the_range_ends_is_accepted(tmp_path, capsys):
    for snr in ("-50", "80"):
        assert main(["simulate", "--duration-s", "0.25", "--snr-db", snr, "--out", str(tmp_path / snr)]) == 0


@pytest.mark.parametrize("command", ["simulate --speech", "simulate --noise", "enhance"])
def test_missing_input_file_says_no_such_file(command, tmp_path, capsys):
    missing = str(tmp_path / "nope.wav")
    argv = {
        "simulate --speech": ["simulate", "--speech", missing, "--out", str(tmp_path / "o")],
        "simulate --noise": ["simulate", "--noise", missing, "--out", str(tmp_path / "o")],
        "enhance": ["enhance", missing, str(tmp_path / "o.wav"), "-e", "eb"],
    }[command]
    assert main(argv) == 2
    _one_error_line(capsys, f"no such file: {missing}")


def test_three_channel_file_names_three_channels_and_suggests_two(tmp_path, rng, capsys):
    path = tmp_path / "three.wav"
    sf.write(path, 0.1 * rng.standard_normal((FS // 4, 3)), FS, subtype="FLOAT")
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "eb"]) == 2
    _one_error_line(capsys, "has 3 channel(s)", "--channels 0,1")
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "eb", "--channels", "0,5"]) == 2
    _one_error_line(capsys, "has 3 channel(s)", "--channels 0,1")


def test_dask_hint_is_an_install_command_that_works_from_a_checkout(monkeypatch):
    from benchmarks.run.executors import DaskExecutor, ExecutorError

    monkeypatch.setitem(sys.modules, "distributed", None)  # makes `import distributed` fail
    with pytest.raises(ExecutorError) as info:
        DaskExecutor(workers=1)
    # 'scenesim' is not on PyPI: the hint must name dask itself, and the editable extra.
    assert "pip install 'dask[distributed]'" in str(info.value)
    assert "pip install -e '.[dask]'" in str(info.value)
    assert "scenesim[dask]'" not in str(info.value).replace("-e '.[dask]'", "")


def test_input_shorter_than_latency_warns(tmp_path, capsys):
    from enhancers.core.registry import make

    latency = make("eb-ss").tags.latency_samples
    assert latency > 1
    path = tmp_path / "short.wav"
    sf.write(path, np.zeros((latency, 2)), FS, subtype="FLOAT")
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "eb-ss"]) == 0
    err = capsys.readouterr().err
    assert f"scenesim: warning: {path} has {latency} samples, no more than" in err


def test_warnings_print_as_scenesim_warning_lines(capsys):
    import warnings

    from benchmarks.cli.console import cli_warnings

    with cli_warnings():
        warnings.warn("scenesim: the cache is full", UserWarning, stacklevel=1)
        warnings.warn("scenesim: the cache is full", UserWarning, stacklevel=1)  # printed once
        warnings.warn("plain text", RuntimeWarning, stacklevel=1)
    assert capsys.readouterr().err.splitlines() == [
        "scenesim: warning: the cache is full",
        "scenesim: warning: plain text",
    ]


def _console(*argv, cwd=None, umask=None):
    exe = shutil.which("scenesim") or str(Path(sys.executable).with_name("scenesim"))
    return subprocess.run([exe, *argv], capture_output=True, text=True, cwd=cwd, timeout=300,
                          preexec_fn=(lambda: os.umask(umask)) if umask is not None else None)


def test_version_flag_prints_the_package_version():
    from scenesim import __version__

    r = _console("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"scenesim {__version__}"


def test_console_shows_no_python_warning_format_when_t30_misses(tmp_path):
    # A long thin room: Sabine's formula is off by ~+77 % here (measured T30 1.41 s for 0.8 s).
    r = _console("rir", "--dims", "8", "3", "2.5", "--rt60", "0.8", "--rt60-method", "sabine", "--mic", "2", "1.5",
                 "1.2", "--source", "6", "1.2", "1.3", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("scenesim: warning: the measured T30"), r.stderr
    assert "--rt60-method calibrated" in lines[0] and "UserWarning" not in r.stderr


def test_rt60_miss_within_10_percent_or_absorption_given_does_not_warn(tmp_path, capsys):
    # A cube at RT60 0.5 s: Sabine's absorption gives a measured T30 within 10 % of the target
    # here; at 0.3 s it is 18 % short, which warns (the threshold sits between the two).
    argv = ["rir", "--dims", "5", "5", "5", "--mic", "2.1", "2.4", "1.6", "--source", "1.2", "1.3", "1.1",
            "--rt60-method", "sabine"]
    assert main([*argv, "--rt60", "0.5", "--out", str(tmp_path / "a")]) == 0
    assert main([*argv, "--absorption", "0.2", "--out", str(tmp_path / "b")]) == 0
    assert "warning" not in capsys.readouterr().err
    assert main([*argv, "--rt60", "0.3", "--out", str(tmp_path / "c")]) == 0
    assert "-18 % off --rt60 0.3 s" in capsys.readouterr().err


def test_rir_rt60_defaults_to_the_calibrated_room_every_sweep_uses(tmp_path, capsys):
    """One default for --rt60: the closed-loop calibration (scenesim.calibrate_room's), whose RIR measures the
    asked T30 -- not Sabine's formula, 18 % short in this cube at 0.3 s (the test above)."""
    from scenesim.room.rt60 import measure_rt60

    argv = ["rir", "--dims", "5", "5", "5", "--mic", "2.1", "2.4", "1.6", "--source", "1.2", "1.3", "1.1",
            "--rt60", "0.3", "--out", str(tmp_path / "c")]
    assert main(argv) == 0
    assert "warning" not in capsys.readouterr().err
    meta = json.loads((tmp_path / "c" / "rir.json").read_text())
    assert meta.get("rt60_method", "calibrated") == "calibrated"
    t30 = float(np.mean(measure_rt60(np.load(tmp_path / "c" / "rir.npy"), 16000, method="T30")))
    assert abs(t30 / 0.3 - 1) < 0.10  # the calibration's own tolerance; Sabine's was -18 %


def _strict_json(path: Path):
    def refuse(name):
        raise ValueError(f"{path.name} holds {name}, which is not JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_json_outputs_hold_null_not_nan(tmp_path, capsys):
    from scenesim.files import to_json

    assert to_json({"a": float("nan"), "b": [np.float64("inf"), 1.5]}) == '{"a": null, "b": [null, 1.5]}'
    out = tmp_path / "r"
    # One mic: the cross-check's inter-mic delay error is NaN and must be written as null.
    assert main(["rir", "--dims", "4", "5", "3", "--absorption", "0.5", "--mic", "2", "2", "1.5",
                 "--source", "1", "1", "1", "--compare", "pyroomacoustics", "--out", str(out)]) == 0
    check = _strict_json(out / "crosscheck.json")
    assert check["inter_mic_delay_error_samples"] is None
    _strict_json(out / "rir.json")


def test_rir_compare_does_not_change_the_saved_rir(tmp_path, capsys):
    argv = [*RIR_ROOM, *PAIR, "--source", "1", "1.2", "1.1", "--length", "0.2"]
    assert main([*argv, "--out", str(tmp_path / "plain")]) == 0
    assert main([*argv, "--out", str(tmp_path / "cmp"), "--compare", "pyroomacoustics"]) == 0
    plain, cmp = np.load(tmp_path / "plain" / "rir.npy"), np.load(tmp_path / "cmp" / "rir.npy")
    np.testing.assert_array_equal(cmp, plain)  # same settings, same renderer: bit-identical
    assert _strict_json(tmp_path / "cmp" / "rir.json")["max_order"] is None


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_output_files_are_readable_as_the_umask_says(umask, tmp_path, stereo_wav):
    sim, enh = tmp_path / "sim", tmp_path / "enh.wav"
    r1 = _console("simulate", "--duration-s", "0.25", "--out", str(sim), umask=umask)
    r2 = _console("enhance", str(stereo_wav), str(enh), "-e", "passthrough", umask=umask)
    assert r1.returncode == 0 and r2.returncode == 0, r1.stderr + r2.stderr
    want = 0o666 & ~umask
    for path in [*sim.iterdir(), enh]:
        assert path.stat().st_mode & 0o777 == want, (path.name, oct(path.stat().st_mode))


def _noise_only_data_dir(tmp_path, rng) -> Path:
    root = tmp_path / "data"
    (root / "noise").mkdir(parents=True)
    (root / "speech").mkdir()
    sf.write(root / "noise" / "wind_1.wav", 0.1 * rng.standard_normal(2 * FS), FS, subtype="FLOAT")
    (root / "speech" / "broken.wav").write_bytes(b"RIFF not really a wav")
    return root


def test_explicit_data_dir_with_unusable_speech_is_an_error(tmp_path, rng, capsys):
    root = _noise_only_data_dir(tmp_path, rng)
    out = tmp_path / "out"
    argv = ["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--data-dir", str(root), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"scenesim: error: no usable speech in {root}/speech" in err
    assert "broken.wav" in err  # the skipped file is named (a warning line before the error)
    assert not (out / "results.sqlite").exists()


@pytest.mark.filterwarnings("ignore:skipping 1 unusable")
def test_default_data_dir_with_unusable_speech_still_falls_back(tmp_path, rng):
    from data_recipes import open_data
    from data_recipes.source import DataFallbackWarning

    root = _noise_only_data_dir(tmp_path, rng)
    with pytest.warns(DataFallbackWarning, match="using the built-in artificial voice"):
        source = open_data(root)  # $SCENESIM_DATA / library default: the fallback stays
    assert "wind" in source.local_noise_types


def test_simulate_source_on_a_mic_names_the_distance_option(tmp_path, capsys):
    # Near field, azimuth 0: the front mic sits at +spacing/2 = 10.7 mm from the pair centre.
    argv = ["simulate", "--duration-s", "0.25", "--near-field", "--speech-az", "0", "--distance-m", "0.0107",
            "--out", str(tmp_path)]
    assert main(argv) == 2
    _one_error_line(capsys, "--distance-m=0.0107", "between or on the mics")
    assert not (tmp_path / "mixture.wav").exists()


def test_rir_refuses_to_write_a_non_finite_rir(tmp_path, monkeypatch, capsys):
    # Defence in depth behind the 1 mm rule: whatever makes the renderer return NaN, no file.
    import scenesim.room.render

    def nan_rir(*args, **kwargs):
        return np.full((2, 100), np.nan)

    monkeypatch.setattr(scenesim.room.render, "room_rir", nan_rir)
    assert main([*RIR_ROOM, *PAIR, "--source", "1", "1", "1", "--out", str(tmp_path)]) == 2
    _one_error_line(capsys, "a finite RIR")
    assert not (tmp_path / "rir.npy").exists() and not (tmp_path / "rir.json").exists()


def test_read_audio_says_no_such_file_and_is_a_directory(tmp_path):
    from scenesim.audio import read_audio
    from scenesim.errors import DataError

    with pytest.raises(DataError, match=f"^no such file: {tmp_path / 'nope.wav'}$"):
        read_audio(tmp_path / "nope.wav")
    with pytest.raises(DataError, match="is a directory, not an audio file"):
        read_audio(tmp_path)


@pytest.mark.parametrize("args, option", [
    (["--length", "-1"], "--length=-1.0"),
    (["--max-order", "-1"], "--max-order=-1"),
    (["--source", "9", "1", "1"], "--source=(9.0, 1.0, 1.0)"),
])
def test_rir_errors_name_the_option_typed(args, option, tmp_path, capsys):
    argv = [*RIR_ROOM, *PAIR, "--source", "1", "1", "1", "--out", str(tmp_path), *args]
    assert main(argv) == 2
    _one_error_line(capsys, f"Parameter {option} is invalid")


def test_enhance_output_without_audio_extension_fails_before_processing(tmp_path, stereo_wav, capsys):
    assert main(["enhance", str(stereo_wav), str(tmp_path / "out.txt"), "-e", "passthrough"]) == 2
    _one_error_line(capsys, "Parameter OUT=", "a file name ending in .wav")
