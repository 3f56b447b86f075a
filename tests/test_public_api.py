"""The fixed public surface of contract.md: names outside checks and users' scripts rely on."""

import subprocess
import sys

import numpy as np
import pytest

import enhancers
import scenesim


def test_contract_example_runs_end_to_end():
    # contract.md "Python API", line by line.
    room = scenesim.ShoeBox(dims_m=(6, 5, 3), absorption=0.3)
    h = scenesim.image_source_rir(room, (2.0, 3.0, 1.5), [(4.0, 2.0, 1.2), (4.0, 2.0214, 1.2)], fs=16000)
    assert h.ndim == 2 and h.shape[0] == 2
    # Physical scale, t = 0 at emission: the direct path peaks at r/c with about 1/(4 pi r).
    r = np.linalg.norm(np.subtract((2.0, 3.0, 1.5), (4.0, 2.0, 1.2)))
    assert abs(int(np.argmax(h[0])) - r / 343.0 * 16000) <= 1
    names = enhancers.available()
    for fixed in ("eb", "ss", "eb-ss", "passthrough"):
        assert fixed in names
    e = enhancers.make("ss", alpha=0.9)
    assert e.params.alpha == 0.9
    x = np.random.default_rng(0).standard_normal((2, 16000)) * 0.1
    result = enhancers.make("eb-ss").process(x, fs=16000)
    assert result.output.shape == (1, 16000)
    # Shadow filtering: replay is linear and reproduces the output (contract: replay(mixture) == output).
    half = 0.5 * x
    np.testing.assert_allclose(result.replay(half) + result.replay(x - half), result.output, atol=1e-9)


def test_room_by_rt60_and_per_wall_absorption():
    assert scenesim.ShoeBox(dims_m=(6, 5, 3), rt60_s=0.4).sabine_rt60_s == pytest.approx(0.4, rel=1e-9)
    walls = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
    np.testing.assert_array_equal(scenesim.ShoeBox(dims_m=(6, 5, 3), absorption=walls).wall_absorption, walls)


def test_error_root_and_parameter_error():
    assert issubclass(scenesim.ParameterError, scenesim.ScenesimError)
    assert issubclass(scenesim.ParameterError, ValueError)
    with pytest.raises(scenesim.ParameterError, match="absorption"):
        scenesim.ShoeBox(dims_m=(6, 5, 3), absorption=1.7)


@pytest.mark.parametrize("command", ["bench", "simulate", "enhance", "data", "rir"])
def test_console_script_has_every_sub_command(command):
    out = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli.main", command, "--help"],
        capture_output=True, text=True, timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert "usage: scenesim " + command in out.stdout


def test_lower_layers_do_not_import_higher_ones():
    # style.md lesson 13, checked in a fresh interpreter so no other test's imports leak in.
    code = (
        "import sys, scenesim, enhancers, data_recipes\n"
        "bad = [m for m in sys.modules if m.split('.')[0] == 'benchmarks']\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
    code = "import sys, scenesim\nprint([m for m in sys.modules if m.split('.')[0] in ('enhancers', 'data_recipes')])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[]", out.stdout


def test_sensor_model_fixed_names():
    # contract.md "Added fixed names": sweep keys, simulate flags, presets, result columns.
    from benchmarks.run.sweep import PRESETS, parse_sweep
    from benchmarks.store.sqlite import COLUMNS

    sweep = parse_sweep(
        '[axes]\nenhancers = ["passthrough"]\nnoise = ["wind"]\nsnr_db = [0]\n[fixed]\n'
        "mic_gain_db = 0.5\nmic_phase_deg = 2\nmic_highpass_hz = [80, 120]\nself_noise_dba = 30\n"
        'speech_spl_db = 62\nwind_speed_mps = 6\nsnr_band_hz = [100, 7000]\nnoise_field = "wind"\n'
    )
    cond = sweep.conditions()[0]
    assert (cond.mic_gain_db, cond.mic_phase_deg, cond.mic_highpass_hz) == (0.5, 2.0, (80.0, 120.0))
    assert (cond.self_noise_dba, cond.speech_spl_db, cond.wind_speed_mps) == (30.0, 62.0, 6.0)
    assert cond.snr_band_hz == (100.0, 7000.0)
    assert {"phone", "mismatch", "thesis", "reverb", "angles", "smoke"} <= set(PRESETS)
    for col in ("snr_i_hagerman_db", "mic_gain_db", "mic_phase_deg", "self_noise_dba", "speech_spl_db"):
        assert col in COLUMNS
    out = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli.main", "simulate", "--help"], capture_output=True, text=True, timeout=120
    )
    for flag in ("--mic-gain-db", "--mic-phase-deg", "--mic-highpass-hz", "--self-noise-dba", "--speech-spl-db"):
        assert flag in out.stdout


def test_added_fixed_names_of_the_robust_eb_reverberation_and_peers_issues():
    # contract.md "Added fixed names": enhancers, presets, result columns, hybrid ISM, commands.
    import benchmarks
    from benchmarks.run.sweep import PRESETS
    from benchmarks.store.sqlite import COLUMNS

    names = enhancers.available()
    for name in ("eb-subband", "mic-calibration", "eb-robust", "eb-robust-ss", "mmse-lsa",
                 "superdirective", "webrtc-ns", "rnnoise"):  # fmt: skip
        assert name in names, name
    assert {"phone", "mismatch", "distance", "peers"} <= set(PRESETS)
    for col in ("sinr_in_db", "sinr_out_db", "sinr_i_db", "drr_in_db", "drr_out_db", "c50_in_db",
                "c50_out_db", "srmr_in", "srmr_out", "t30_s", "edt_s", "drr_rir_db", "c50_rir_db"):  # fmt: skip
        assert col in COLUMNS, col
    assert callable(benchmarks.load_results)


def test_fixed_names_of_the_learned_peer_dereverberation_and_dnsmos_issue():
    # Issue 19: enhancers (listed even when their extra is missing), DNSMOS columns, score command.
    from benchmarks.cli.main import build_parser
    from benchmarks.store.sqlite import COLUMNS

    names = enhancers.available()
    for name in ("dfn3", "eb-robust-dfn3", "wpe", "wpe-eb-robust", "wpe-eb-robust-ss"):
        assert name in names, name
    for col in ("dnsmos_sig", "dnsmos_bak", "dnsmos_ovrl", "dnsmos_sig_in", "dnsmos_bak_in", "dnsmos_ovrl_in"):
        assert col in COLUMNS, col
    assert build_parser().parse_args(["score", "a.wav", "--ref", "b.wav", "--out", "c.csv"]).command == "score"
    room = scenesim.ShoeBox(dims_m=(5, 4, 3), absorption=0.3)
    h = scenesim.image_source_rir(room, (1.0, 1.0, 1.5), [(3.0, 2.0, 1.2)], fs=16000, method="hybrid")
    assert h.shape[0] == 1 and np.all(np.isfinite(h))
    for argv in (["bench", "compare", "--help"], ["plugin", "new", "--help"]):
        out = subprocess.run([sys.executable, "-m", "benchmarks.cli.main", *argv],
                             capture_output=True, text=True, timeout=120)  # fmt: skip
        assert out.returncode == 0, out.stderr
