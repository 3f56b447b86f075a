"""Issue 33, bad inputs by class: one representative case per class of the probe's failures.

Each test feeds what a new user typed and checks the one-line error names it (or, for inputs that
are fine, that the result is right); the class number is the issue's.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main
from scenesim.errors import ParameterError, ScenesimError

FS = 16000


@pytest.fixture
def mono_wav(tmp_path, rng):
    path = tmp_path / "speech.wav"
    sf.write(path, 0.1 * rng.standard_normal(FS), FS, subtype="FLOAT")
    return path


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and "Traceback" not in "\n".join(err)
    return err[-1]


# -- class 1: rates ------------------------------------------------------------------------


def test_class1_api_rates_are_held_to_the_range_of_fs(rng):
    import enhancers
    from benchmarks.metrics.scoring import score

    x = rng.standard_normal(FS)
    with pytest.raises(ParameterError, match=r"fs=100000000 .*\[8000, 192000\] Hz"):
        score(x, 100_000_000)
    with pytest.raises(ParameterError, match=r"fs=1 .*\[8000, 192000\] Hz"):
        enhancers.make("ss").process(x[None], fs=1)


def test_class1_a_file_score_cannot_read_is_named_with_its_reason_on_stderr(tmp_path, mono_wav, capsys):
    bad = tmp_path / "notes.wav"
    bad.write_text("not audio")
    assert main(["score", str(bad), "--ref", str(mono_wav), "--no-dnsmos"]) == 1
    err = capsys.readouterr().err
    assert re.search(r"failed: \S*notes\.wav: cannot read audio file", err) and "Traceback" not in err


def test_class1_a_data_folder_of_bad_rates_names_the_file_in_its_error(tmp_path, capsys):
    from _wav_headers import wav_with_rate

    (tmp_path / "data" / "speech").mkdir(parents=True)
    (tmp_path / "data" / "noise").mkdir()
    wav_with_rate(tmp_path / "data" / "speech" / "talk.wav", 1)
    assert main(["thesis", "evaluate", "--data-dir", str(tmp_path / "data"), "--no-pesq", "--duration", "1"]) == 2
    line = _error_line(capsys)
    assert "talk.wav" in line and "1 Hz" in line


# -- class 2: an output that is an input ---------------------------------------------------


def test_class2_enhance_trace_naming_the_input_is_refused_and_the_input_kept(tmp_path, mono_wav, capsys):
    before = mono_wav.read_bytes()
    assert main(["enhance", str(mono_wav), str(tmp_path / "out.wav"), "-e", "ss", "--trace", str(mono_wav)]) == 2
    assert "--trace=" in _error_line(capsys) and mono_wav.read_bytes() == before
    assert not (tmp_path / "out.wav").exists()


def test_class2_simulate_speech_inside_out_under_a_written_name_is_refused(tmp_path, mono_wav, capsys):
    out = tmp_path / "scene"
    out.mkdir()
    speech = out / "mixture.wav"
    speech.write_bytes(mono_wav.read_bytes())
    assert main(["simulate", "--speech", str(speech), "--out", str(out)]) == 2
    assert "--speech=" in _error_line(capsys) and speech.read_bytes() == mono_wav.read_bytes()


# -- class 4: sizes ------------------------------------------------------------------------


@pytest.mark.parametrize(("option", "value"), [("--trials", "100000000"), ("--workers", "100000"),
                                               ("--test-seeds", "100000000")])
def test_class4_tune_sizes_are_refused_before_work_naming_the_option(option, value, tmp_path, capsys):
    pytest.importorskip("optuna")
    sizes = {"--trials": "2", **{option: value}}
    args = ["tune", "ss", "--sweep", "smoke", "--param", "alpha=0.8:0.99", "--objective", "mean:snr_i_db",
            "--out", str(tmp_path / "t")] + [x for kv in sizes.items() for x in kv]
    assert main(args) == 2
    assert f"{option}={value}" in _error_line(capsys)
    assert not (tmp_path / "t").exists()  # a refused command leaves nothing behind, lock file included


def test_class4_bench_run_workers_is_bounded(tmp_path, capsys):
    assert main(["bench", "run", "smoke", "--workers", "100000", "--out", str(tmp_path / "b")]) == 2
    assert "--workers=100000" in _error_line(capsys) and not (tmp_path / "b").exists()


# -- class 5: stores -----------------------------------------------------------------------


def test_class5_a_load_results_filter_no_row_holds_is_named_with_the_values_there(tmp_path):
    import benchmarks

    pytest.importorskip("pandas")
    assert main(["bench", "run", "smoke", "--limit", "1", "--workers", "1", "--no-report",
                 "--out", str(tmp_path)]) == 0
    with pytest.raises(ScenesimError, match=r"enhancers='eb-sss' matches no row .*'eb-ss'"):
        benchmarks.load_results(tmp_path, enhancers="eb-sss")
    df = benchmarks.load_results(tmp_path, enhancers=["eb", "ss"])
    assert sorted(df.enhancer) == ["eb", "ss"]


# -- class 6: the newer commands ------------------------------------------------------------


def test_class6_listen_count_zero_names_the_option(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["listen", str(tmp_path), "--count", "0"])
    assert "--count" in _error_line(capsys)


# -- class 7: degenerate scores ------------------------------------------------------------


def test_class7_a_file_shorter_than_a_frame_scores_empty_with_reasons(tmp_path, rng, capsys):
    path = tmp_path / "blip.wav"
    sf.write(path, 0.1 * rng.standard_normal(10), FS, subtype="FLOAT")
    assert main(["score", str(path), "--ref", str(path), "--no-dnsmos", "--out", str(tmp_path / "s.csv")]) == 0
    import csv

    row = next(csv.DictReader(open(tmp_path / "s.csv")))
    assert row["stoi"] == "" and "STOI: too little active speech" in row["error"]
    assert math.isclose(float(row["duration_s"]), 10 / FS, rel_tol=1e-9)
    assert "Traceback" not in capsys.readouterr().err


def test_class7_the_stoi_pair_of_less_than_a_frame_is_undefined():
    from benchmarks.metrics.stoi_pair import stoi_estoi

    assert stoi_estoi(np.ones(100), np.ones(100), 10000) is None


def test_class4_a_calibration_target_past_the_physical_rt60_names_rt60_not_the_rir_length():
    import scenesim

    with pytest.raises(ParameterError, match=r"rt60_s=100000\.0 .*\[0, 20\] s"):
        scenesim.calibrate_room((5.0, 4.0, 3.0), 1e5)


def test_class4_synthesized_noise_is_bounded_before_it_is_allocated():
    from data_recipes import synthesize_noise

    with pytest.raises(ParameterError, match=r"n_samples=1000000000000 .*\[1, 9600000\]"):
        synthesize_noise("babble", 10**12, fs=FS, rng=np.random.default_rng(0))


def test_class7_dnsmos_of_silence_is_undefined_with_its_reason():
    pytest.importorskip("onnxruntime")
    from benchmarks.metrics import dnsmos
    from benchmarks.metrics.scoring import score

    if not dnsmos.installed():
        pytest.skip('DNSMOS extra not installed: pip install "scenesim[dnsmos]"')
    row = score(np.zeros(3 * FS), FS, dnsmos=True)
    assert row["dnsmos_ovrl"] is None and row["dnsmos_p808"] is None
    assert "DNSMOS: the scored signal is silent" in row["error"]
