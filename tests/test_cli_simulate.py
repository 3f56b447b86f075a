"""``scenesim simulate``: the four WAV files, their shapes, scene.json, errors.

Run in-process through ``benchmarks.cli.main.main`` (same code path as the console script).
"""

from __future__ import annotations

import json

import numpy as np
import soundfile as sf

from benchmarks.cli.main import main
from scenesim.audio import read_audio, write_audio

FS = 16000
WAVS = ("mixture", "speech_image", "noise_image", "reference")


def read_all(out):
    return {name: read_audio(out / f"{name}.wav")[0] for name in WAVS}


def test_default_run_writes_four_wavs_with_the_right_shapes(tmp_path):
    out = tmp_path / "run"
    assert main(["simulate", "--out", str(out), "--duration-s", "1.0", "--snr-db", "5"]) == 0
    sig = read_all(out)
    assert {k: v.shape for k, v in sig.items()} == {
        "mixture": (2, FS),
        "speech_image": (2, FS),
        "noise_image": (2, FS),
        "reference": (1, FS),
    }
    for name in WAVS:
        info = sf.info(str(out / f"{name}.wav"))
        assert info.samplerate == FS and info.subtype == "FLOAT"
    # mixture = speech + noise (float32 files: 1e-6), SNR at channel 0 = 5 dB (0.01 dB).
    np.testing.assert_allclose(sig["mixture"], sig["speech_image"] + sig["noise_image"], atol=1e-6)
    snr = 10 * np.log10(np.mean(sig["speech_image"][0] ** 2) / np.mean(sig["noise_image"][0] ** 2))
    np.testing.assert_allclose(snr, 5.0, atol=0.01)
    meta = json.loads((out / "scene.json").read_text())
    assert meta["snr_db"] == 5.0 and meta["n_samples"] == FS and len(meta["key"]) == 64
    assert (
        meta["speech_source"].startswith("builtin:")
        and meta["noise_source"] == "generated:white(seed=0)"
    )
    assert meta["scene"]["speech"]["azimuth_deg"] == 45


def test_run_is_deterministic_and_seed_dependent(tmp_path):
    args = ["simulate", "--duration-s", "0.5", "--noise-type", "pink", "--field", "diffuse"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    assert main([*args, "--out", str(tmp_path / "c"), "--seed", "1"]) == 0
    a, b, c = read_all(tmp_path / "a"), read_all(tmp_path / "b"), read_all(tmp_path / "c")
    for name in WAVS:
        np.testing.assert_array_equal(a[name], b[name])
    assert not np.allclose(a["noise_image"], c["noise_image"])


def test_room_run_with_user_files(tmp_path, rng):
    speech = rng.standard_normal(int(0.8 * 22050)) * 0.1
    write_audio(tmp_path / "s.wav", speech, 22050)  # resampled to 16 kHz on reading
    write_audio(tmp_path / "n.wav", rng.standard_normal((2, FS)) * 0.1, FS)
    out = tmp_path / "room"
    code = main(
        [
            "simulate", "--out", str(out), "--speech", str(tmp_path / "s.wav"),
            "--noise", str(tmp_path / "n.wav"), "--field", "incoherent",
            "--rt60", "0.2", "--room", "4", "3.5", "2.8", "--pair-center", "2", "1.6", "1.4",
        ]
    )  # fmt: skip
    assert code == 0
    sig = read_all(out)
    n = int(np.ceil(0.8 * 22050 * FS / 22050))
    assert sig["mixture"].shape == (2, n) and sig["reference"].shape == (1, n)
    meta = json.loads((out / "scene.json").read_text())
    assert meta["scene"]["room"]["rt60_s"] == 0.2 and meta["speech_source"].endswith("s.wav")


def test_errors_exit_2_with_a_message(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "x"), "--rt60", "0.3"]) == 2
    assert "--rt60" in capsys.readouterr().err
    write_audio(tmp_path / "short.wav", np.zeros(100), FS)
    assert (
        main(
            [
                "simulate",
                "--out",
                str(tmp_path / "y"),
                "--duration-s",
                "0.5",
                "--noise",
                str(tmp_path / "short.wav"),
            ]
        )
        == 2
    )
    assert "noise_signals[0]" in capsys.readouterr().err
    assert (
        main(
            [
                "simulate",
                "--out",
                str(tmp_path / "z"),
                "--room",
                "3",
                "3",
                "3",
                "--rt60",
                "0.3",
                "--distance-m",
                "5",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err  # names the option typed, and the source it placed
    assert "--distance-m=5.0" in err and "speech source would be at" in err
    assert not (tmp_path / "x").exists()


def test_sensor_flags_write_the_mics_outputs_and_the_self_noise(tmp_path):
    # Oracle: the sensor model itself -- at broadside both mics receive the same wave, so
    # the rear/front cross-spectrum of the written speech image is the asked mismatch, and
    # noise_image = acoustic noise + self_noise (float WAVs, so to float32 rounding).
    import json

    import numpy as np

    from benchmarks.cli.main import main
    from scenesim.audio import read_audio

    out = tmp_path / "s"
    code = main(["simulate", "--out", str(out), "--speech-az", "270", "--mic-gain-db", "0.5",
                 "--mic-phase-deg", "2", "--self-noise-dba", "30", "--field", "wind",
                 "--snr-band-hz", "100", "7000", "--duration-s", "1"])  # fmt: skip
    assert code == 0
    speech, fs = read_audio(out / "speech_image.wav")
    X0, X1 = np.fft.rfft(speech[0].astype(float)), np.fft.rfft(speech[1].astype(float))
    band = slice(20, X0.size - 20)
    ratio = np.sum(X1[band] * np.conj(X0[band])) / np.sum(np.abs(X0[band]) ** 2)
    np.testing.assert_allclose(abs(ratio), 10 ** (0.5 / 20), rtol=1e-4)
    np.testing.assert_allclose(np.rad2deg(np.angle(ratio)), 2.0, atol=0.01)
    self_noise, _ = read_audio(out / "self_noise.wav")
    assert self_noise.shape == speech.shape and np.std(self_noise) > 0
    meta = json.loads((out / "scene.json").read_text())
    assert meta["sensors"]["mic_gain_db"] == 0.5 and meta["sensors"]["self_noise_dba"] == 30.0
    assert meta["scene"]["snr_band_hz"] == [100, 7000]


def test_sensor_flag_errors_name_the_flag(tmp_path, capsys):
    from benchmarks.cli.main import main

    assert main(["simulate", "--out", str(tmp_path / "x"), "--mic-gain-db", "30"]) == 2
    err = capsys.readouterr().err
    assert "--mic-gain-db=30.0" in err and len(err.strip().splitlines()) == 1
    assert main(["simulate", "--out", str(tmp_path / "x"), "--mic-highpass-hz", "1", "2", "3"]) == 2
    assert "--mic-highpass-hz" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
