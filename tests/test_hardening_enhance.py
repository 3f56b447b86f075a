"""Issue 15 part 2, ``scenesim enhance``: formats work or are refused before the work, OUT == IN
is refused, impossible geometry/channel options are refused, a cut-off WAV is warned about."""

from __future__ import annotations

import os

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main


@pytest.fixture
def stereo(tmp_path):
    path = tmp_path / "in.wav"
    sf.write(path, 0.05 * np.random.default_rng(3).standard_normal((8000, 2)), 16000, subtype="FLOAT")
    return path


def _error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("scenesim: error:"), err
    return err[0]


def test_flac_output_is_written_as_pcm_and_says_so(stereo, tmp_path, capsys):
    out = tmp_path / "out.flac"
    assert main(["enhance", str(stereo), str(out), "-e", "eb"]) == 0
    assert sf.info(out).subtype == "PCM_24" and sf.read(out)[0].shape == (8000,)
    assert "written as PCM_24" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args, needles",
    [(["OUT.ogg"], ("OUT=", ".wav or .flac")), (["IN"], ("OUT=", "other than IN")),
     (["OUT.wav", "--c-mps", "0"], ("--c-mps=0.0", "[300, 400] m/s")),
     (["OUT.wav", "--channels", "0,0"], ("--channels='0,0'", "distinct")),
     (["OUT.wav", "--channels", "-1,0"], ("--channels='-1,0'", "indices in 0..1")),
     (["OUT.wav", "--fs", "10000000"], ("--fs=10000000", "192000")),
     (["OUT.wav", "--spacing-m", "100"], ("--spacing-m=100.0", "[0.002, 0.5] m"))],
)  # fmt: skip
def test_bad_enhance_options_are_refused_before_the_work(args, needles, stereo, tmp_path, capsys):
    before = stereo.read_bytes()
    out = str(stereo) if args[0] == "IN" else str(tmp_path / args[0])
    assert main(["enhance", str(stereo), out, "-e", "eb", *args[1:]]) == 2
    line = _error(capsys)
    for needle in needles:
        assert needle in line, (needle, line)
    assert stereo.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.wav"]  # nothing written


def test_wav_shorter_than_its_header_is_warned_about(tmp_path, capsys):
    path = tmp_path / "cut.wav"
    sf.write(path, np.zeros((16000, 2)), 16000, subtype="PCM_16")
    os.truncate(path, os.path.getsize(path) - 4 * 5000)  # 5000 stereo 16-bit frames gone
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "ss"]) == 0
    err = capsys.readouterr().err
    assert "scenesim: warning:" in err and "11000 of 16000 samples" in err, err


def test_complete_wav_gives_no_truncation_warning(stereo, tmp_path, capsys):
    assert main(["enhance", str(stereo), str(tmp_path / "o.wav"), "-e", "ss"]) == 0
    assert "shorter than its header" not in capsys.readouterr().err
