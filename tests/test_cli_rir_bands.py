"""`scenesim rir` with octave-band absorption, per-band RT60 and air absorption (issue 10)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.cli.main import main

pytest.importorskip("pyroomacoustics")


def test_rir_band_absorption_air_compare(tmp_path, capsys):
    """--band-absorption + --air with --compare prints and saves the agreement figures; tolerances
    as tests/test_crosscheck_bands.py (rel L2 2e-2, 0.15 dB, 2 %; measured 7.6e-3, 0.072 dB, 1.1 %)."""
    out = tmp_path / "rir"
    rc = main([
        "rir", "--dims", "6", "5", "3", "--band-absorption", "0.1", "0.15", "0.25", "0.35", "0.45", "0.55", "0.6",
        "--air", "--temperature", "20", "--humidity", "40", "--source", "1.2", "1.7", "1.4",
        "--pair-center", "4.1", "3", "1.5", "--max-order", "15", "--out", str(out), "--compare", "pyroomacoustics",
    ])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "octave-band materials + air absorption" in printed and "air ISO 9613-1" in printed
    numbers = json.loads((out / "crosscheck.json").read_text())
    assert max(numbers["rel_l2"]) < 2e-2 and numbers["max_band_energy_db"] < 0.15
    assert numbers["max_t30_rel_diff"] < 0.02 and len(numbers["air_iso9613_db_per_km"]) == 7
    meta = json.loads((out / "rir.json").read_text())
    assert meta["bands_hz"][0] == 125.0 and meta["air"]["humidity_pct"] == 40.0
    assert np.asarray(meta["wall_absorption"]).shape == (6, 7)
    assert np.all(np.isfinite(np.load(out / "rir.npy")))


def test_rir_band_rt60_is_calibrated(tmp_path):
    """--band-rt60 builds exactly calibrate_room(dims, targets, bands_hz=octaves) (oracle: the
    library call) and records the targets."""
    out = tmp_path / "rir"
    targets = ["0.5", "0.45", "0.4", "0.35", "0.3", "0.3", "0.3"]
    rc = main(["rir", "--dims", "5", "4", "3", "--band-rt60", *targets, "--source", "1", "1", "1.4",
               "--mic", "3.5", "2.5", "1.5", "--out", str(out)])
    assert rc == 0
    meta = json.loads((out / "rir.json").read_text())
    assert meta["target_rt60_s"] == [float(t) for t in targets]
    from scenesim.room.bands import OCTAVE_CENTERS_HZ
    from scenesim.room.calibration import calibrate_room

    room = calibrate_room((5, 4, 3), tuple(map(float, targets)), bands_hz=OCTAVE_CENTERS_HZ)
    np.testing.assert_array_equal(np.asarray(meta["wall_absorption"]), room.wall_absorption)


@pytest.mark.parametrize(("extra", "name"), [(["--band-absorption", "0.1", "0.2"], "band_absorption"),
                                             (["--absorption", "0.3", "--air", "--humidity", "150"], "humidity_pct")])
def test_rir_band_bad_input(tmp_path, capsys, extra, name):
    rc = main(["rir", "--dims", "6", "5", "3", *extra, "--source", "1", "1", "1", "--mic", "3", "2", "1",
               "--out", str(tmp_path)])
    assert rc == 2 and name in capsys.readouterr().err
