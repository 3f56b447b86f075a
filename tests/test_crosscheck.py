"""Agreement with pyroomacoustics 0.10.1 (outside implementation) and the `scenesim rir` CLI."""

from __future__ import annotations

import json

import numpy as np
import pyroomacoustics as pra
import pytest
import soundfile as sf

from benchmarks.cli.main import main
from scenesim.errors import ParameterError
from scenesim.room.crosscheck import compare_with_pyroomacoustics, plot_crosscheck
from scenesim.room.shoebox import ShoeBox


def _random_scene(seed: int):
    """Seeded random room: dims, per-wall absorption, source, a 2.14 cm pair, order, fs."""
    rng = np.random.default_rng(1000 + seed)
    dims = rng.uniform([2.5, 2.5, 2.2], [8.0, 7.0, 4.0])
    room = ShoeBox(tuple(dims), tuple(rng.uniform(0.05, 0.9, 6)))
    src = rng.uniform(0.3, dims - 0.3)
    mic = rng.uniform(0.35, dims - 0.35)
    mics = np.stack([mic, mic - [0.0214, 0.0, 0.0]])
    # Mostly small orders to keep the suite fast; every 6th scene a large one (up to 30).
    max_order = int(rng.integers(20, 31)) if seed % 6 == 0 else int(rng.integers(0, 13))
    fs = int(rng.choice([8000, 16000]))
    return room, src, mics, max_order, fs


@pytest.mark.parametrize("seed", range(24))
def test_agrees_with_pyroomacoustics(seed):
    """Oracle: pyroomacoustics 0.10.1 with the same image set, aligned (40-sample delay removed,
    divided by 4 pi, its 10 Hz high-pass off). Tolerance (algorithms.md section 3): relative L2
    <= 5e-3 per mic and the same argmax. Residual: its window sits on the integer grid and its sinc
    comes from a float32 table (about half each); measured worst 4.2e-3 over 60 rooms."""
    room, src, mics, max_order, fs = _random_scene(seed)
    check = compare_with_pyroomacoustics(room, src, mics, fs=fs, max_order=max_order)
    assert check.max_rel_l2 <= 5e-3, check.rel_l2
    assert check.argmax_equal
    # Inter-mic delay (cross-correlation peak): both place the 1.1-sample lag alike.
    assert abs(check.inter_mic_delay_error_samples) < 0.02


@pytest.mark.parametrize("seed", [0, 5])
def test_fast_renderer_agrees_with_pyroomacoustics(seed):
    """Same oracle and tolerance for the fast renderer (it is within 3e-5 of the exact one)."""
    room, src, mics, max_order, fs = _random_scene(seed)
    check = compare_with_pyroomacoustics(room, src, mics, fs=fs, max_order=max_order, method="fast")
    assert check.max_rel_l2 <= 5e-3 and check.argmax_equal


def test_highpass_setting_restored_and_fields(tmp_path):
    """The cross-check switches pyroomacoustics' high-pass off only for its own run."""
    room = ShoeBox((5.0, 4.0, 3.0), rt60_s=0.3)
    before = pra.constants.get("rir_hpf_enable")
    check = compare_with_pyroomacoustics(room, (1, 1, 1), (3.5, 2.5, 1.6), fs=16000, max_order=25)
    assert pra.constants.get("rir_hpf_enable") == before
    assert np.isnan(check.inter_mic_delay_error_samples)  # one mic
    assert check.n_images > 0 and check.max_order == 25
    # Their and our T30 agree (same image set); both measured on mic 0.
    assert check.t30_ours_s == pytest.approx(check.t30_theirs_s, rel=0.01)
    assert check.their_rt60_error == pytest.approx(check.t30_theirs_s / 0.3 - 1.0)
    d = check.to_dict()
    assert "ours" not in d and json.dumps(d)
    path = tmp_path / "check.png"
    plot_crosscheck(check, path=path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_input():
    room = ShoeBox((5.0, 4.0, 3.0), 0.3)
    with pytest.raises(ParameterError, match="max_order"):
        compare_with_pyroomacoustics(room, (1, 1, 1), (3, 2, 1), fs=16000, max_order=None)
    with pytest.raises(ParameterError, match="source_m"):
        compare_with_pyroomacoustics(room, (9, 1, 1), (3, 2, 1), fs=16000, max_order=3)


def test_cli_rir_compare(tmp_path, capsys):
    """`scenesim rir ... --compare pyroomacoustics` writes the RIR, the agreement JSON (rel L2 <= 5e-3,
    the algorithms.md tolerance) and the figure; the WAV holds the same RIR (float32 precision)."""
    out = tmp_path / "rir"
    rc = main([
        "rir", "--dims", "6", "5", "3", "--rt60", "0.3", "--source", "1.2", "2.1", "1.4",
        "--pair-center", "4", "3", "1.5", "--fs", "16000", "--max-order", "12",
        "--out", str(out), "--format", "both", "--compare", "pyroomacoustics",
    ])
    assert rc == 0
    h = np.load(out / "rir.npy")
    assert h.shape[0] == 2
    wav, fs = sf.read(out / "rir.wav", dtype="float64")
    assert fs == 16000
    np.testing.assert_allclose(wav.T, h, rtol=0, atol=1e-7 * np.abs(h).max())
    numbers = json.loads((out / "crosscheck.json").read_text())
    assert max(numbers["rel_l2"]) <= 5e-3 and numbers["argmax_equal"]
    assert (out / "crosscheck.png").stat().st_size > 1000
    meta = json.loads((out / "rir.json").read_text())
    assert meta["max_order"] == 12 and meta["n_taps"] == h.shape[1]
    assert "rel L2" in capsys.readouterr().out


def test_cli_default_order_and_mics(tmp_path):
    """Without --max-order, --compare uses pyroomacoustics' inverse-Sabine order; --mic repeats."""
    out = tmp_path / "rir"
    rc = main([
        "rir", "--dims", "4", "3.5", "2.7", "--absorption", "0.6", "--source", "1", "1", "1",
        "--mic", "3", "2", "1.5", "--mic", "3.1", "2", "1.5", "--fs", "8000", "--out", str(out),
        "--compare", "pyroomacoustics",
    ])
    assert rc == 0
    _, expected_order = pra.inverse_sabine(ShoeBox((4, 3.5, 2.7), 0.6).sabine_rt60_s, [4, 3.5, 2.7])
    assert json.loads((out / "crosscheck.json").read_text())["max_order"] == expected_order
    assert np.load(out / "rir.npy").shape[0] == 2


@pytest.mark.parametrize(
    ("extra", "name"),
    [
        (["--absorption", "1.5"], "absorption"),
        (["--absorption", "0.3", "0.3"], "absorption"),
        (["--rt60", "0.01"], "--rt60"),  # errors name the option typed (issue 11)
    ],
)
def test_cli_bad_input(tmp_path, capsys, extra, name):
    rc = main(["rir", "--dims", "6", "5", "3", *extra, "--source", "1", "1", "1",
               "--mic", "3", "2", "1", "--out", str(tmp_path)])
    assert rc == 2
    assert name in capsys.readouterr().err


def test_cli_mic_outside(tmp_path, capsys):
    rc = main(["rir", "--dims", "6", "5", "3", "--absorption", "0.3", "--source", "1", "1", "1",
               "--mic", "7", "2", "1", "--out", str(tmp_path)])
    assert rc == 2 and "--mic #1=" in capsys.readouterr().err
