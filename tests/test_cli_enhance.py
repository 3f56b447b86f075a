"""``scenesim enhance``: file in, file out, clear errors (via benchmarks.cli.main.main)."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main
from enhancers.core.registry import make

FS = 16000


@pytest.fixture
def stereo_wav(tmp_path, rng):
    x = 0.1 * rng.standard_normal((2, FS // 2))
    path = tmp_path / "in.wav"
    sf.write(path, x.T, FS, subtype="DOUBLE")
    return path, x


def _read(path):
    data, fs = sf.read(path, dtype="float64", always_2d=True)
    return data.T, fs


def _assert_latency_removed(y, delayed, latency):
    """Oracle: the API's (delayed) output advanced by the declared latency, for a causal enhancer;
    same length as the input; float32 storage bounds the difference (1e-6)."""
    assert latency > 0 and y.shape == delayed.shape
    np.testing.assert_allclose(y[:, : y.shape[1] - latency], delayed[:, latency:], rtol=0, atol=1e-6)


def test_passthrough_writes_reference_mic(tmp_path, stereo_wav, capsys):
    path, x = stereo_wav
    out = tmp_path / "out.wav"
    assert main(["enhance", str(path), str(out), "--enhancer", "passthrough"]) == 0
    y, fs = _read(out)
    assert fs == FS and sf.info(out).subtype == "FLOAT"
    # Float WAV stores float32: exact up to float32 rounding (relative 2^-24).
    np.testing.assert_allclose(y, x[0:1], rtol=2**-23, atol=0)
    assert "latency: 0 samples" in capsys.readouterr().out


def test_das_with_params_and_spacing_matches_api(tmp_path, stereo_wav, capsys):
    path, x = stereo_wav
    out = tmp_path / "das.wav"
    argv = ["enhance", str(path), str(out), "-e", "das", "--param", "fir_taps=16", "--spacing-m", "0.03",
            "--keep-latency"]
    assert main(argv) == 0
    expected = make("das", fir_taps=16, spacing_m=0.03).process(x, FS).output
    y, _ = _read(out)
    # Oracle: the Python API on the same samples (delay kept); float32 storage bounds the difference.
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-7)
    assert "latency: 8 samples (0.500 ms), kept in the output" in capsys.readouterr().out


def test_eb_ss_chain_stage_param(tmp_path, stereo_wav, capsys):
    path, x = stereo_wav
    out = tmp_path / "ebss.wav"
    trace = tmp_path / "trace.npz"
    argv = ["enhance", str(path), str(out), "-e", "eb-ss", "-p", "ss.alpha=0.9", "--trace", str(trace)]
    assert main(argv) == 0
    api = make("eb-ss", ss={"alpha": 0.9})
    y, _ = _read(out)
    _assert_latency_removed(y, api.process(x, FS).output, api.tags.latency_samples)
    assert any(key.startswith("eb__") for key in np.load(trace).files)
    assert "default spacing_m" in capsys.readouterr().err


def test_one_channel_enhancer_uses_reference_mic(tmp_path, stereo_wav, capsys):
    path, x = stereo_wav
    out = tmp_path / "ss.wav"
    assert main(["enhance", str(path), str(out), "-e", "ss"]) == 0
    y, _ = _read(out)
    _assert_latency_removed(y, make("ss").process(x[0:1], FS).output, make("ss").tags.latency_samples)
    assert "using channel 0" in capsys.readouterr().err


def test_wrong_channel_count_names_file_and_count(tmp_path, capsys):
    path = tmp_path / "mono.wav"
    sf.write(path, np.zeros(1000), FS)
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "das"]) == 2
    err = capsys.readouterr().err
    assert "mono.wav has 1 channel(s)" in err and "expects 2" in err


def test_unknown_enhancer_suggests(tmp_path, stereo_wav, capsys):
    path, _ = stereo_wav
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", "passthru"]) == 2
    assert "Did you mean 'passthrough'?" in capsys.readouterr().err


@pytest.mark.parametrize(
    "enhancer, param, name",
    [("das", "fir_taps=abc", "--param fir_taps"), ("das", "nope=1", "--param nope"), ("das", "fir_taps", "--param"),
     ("passthrough", "x=1", "--param x"), ("eb-ss", "ss.alpha=abc", "--param ss.alpha")],
)
def test_bad_param_is_named(tmp_path, stereo_wav, capsys, enhancer, param, name):
    """Issue 33 class 8: the message names the option as typed (--param KEY), not the bare field."""
    path, _ = stereo_wav
    assert main(["enhance", str(path), str(tmp_path / "o.wav"), "-e", enhancer, "-p", param]) == 2
    err = capsys.readouterr().err
    assert f"Parameter {name}=" in err


def test_missing_input_is_data_error(tmp_path, capsys):
    assert main(["enhance", str(tmp_path / "none.wav"), str(tmp_path / "o.wav"), "-e", "das"]) == 2
    assert "none.wav" in capsys.readouterr().err


def test_channel_selection_and_resampling(tmp_path, rng, capsys):
    x = 0.1 * rng.standard_normal((3, 4000))
    path = tmp_path / "three.wav"
    sf.write(path, x.T, 8000, subtype="DOUBLE")
    out = tmp_path / "o.wav"
    # Channel 2 as the reference mic, resampled to 16 kHz (oracle: scenesim.audio.resample).
    assert main(["enhance", str(path), str(out), "-e", "passthrough", "--channels", "2,0", "--fs", "16000"]) == 0
    from scenesim.audio import resample

    y, fs = _read(out)
    assert fs == 16000
    np.testing.assert_allclose(y, resample(x[2:3], 8000, 16000), rtol=0, atol=1e-6)
    assert main(["enhance", str(path), str(out), "-e", "passthrough", "--channels", "0,3"]) == 2
    assert "Parameter --channels='0,3'" in capsys.readouterr().err
