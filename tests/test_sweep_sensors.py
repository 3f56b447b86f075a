"""Sweep keys of the sensor model and the noise fields (issue 8): parsing, errors, expansion."""

from __future__ import annotations

import pytest

from benchmarks.run.runner import build_scene, sensor_columns
from benchmarks.run.sweep import load_sweep, parse_sweep
from scenesim.errors import ConfigError

BASE = """
[axes]
enhancers = ["passthrough"]
noise = ["babble", "factory", "wind"]
snr_db = [0]
seeds = [0, 1, 2]
[fixed]
"""


def _parse(extra: str):
    return parse_sweep(BASE + extra, source="s.toml")


def test_a_field_per_noise_and_drawn_azimuths():
    sweep = _parse(
        'noise_field = {babble = "diffuse", factory = "point", wind = "wind"}\n'
        "noise_az_range_deg = [100, 260]\nwind_speed_mps = 8\n"
    )
    conds = sweep.conditions()
    assert len(conds) == 9
    by = {(c.noise, c.seed): c for c in conds}
    assert {c.noise_field for c in conds if c.noise == "babble"} == {"diffuse"}
    assert all(by[("babble", s)].noise_az_deg is None for s in range(3))
    azs = [by[("factory", s)].noise_az_deg for s in range(3)]
    assert all(100 <= a <= 260 for a in azs) and len(set(azs)) == 3
    assert azs == [c.noise_az_deg for c in _parse(
        'noise_field = {babble = "diffuse", factory = "point", wind = "wind"}\nnoise_az_range_deg = [100, 260]\n'
    ).conditions() if c.noise == "factory"]  # fmt: skip  # seeded: the same draw every time
    assert by[("wind", 0)].wind_speed_mps == 8.0 and by[("factory", 0)].wind_speed_mps == 5.0


def test_field_table_must_cover_every_noise():
    with pytest.raises(ConfigError, match=r"line \d+: key 'fixed.noise_field': no field for noise 'wind'"):
        _parse('noise_field = {babble = "diffuse", factory = "point"}\n')


@pytest.mark.parametrize(
    "line, message",
    [("mic_gain_db = 11", "mic_gain_db"), ('self_noise_dba = "loud"', "'none'"),
     ("snr_band_hz = [7000, 100]", "lo < hi"), ("snr_band_hz = [100, 9000]", "above fs/2"),
     ("mic_highpass_hz = [100, 200, 300]", "front, rear"), ("mic_highpass_hz = 9000", "a corner in Hz"),
     ('noise_field = "fog"', "'point'")],
)  # fmt: skip
def test_bad_sensor_keys_give_one_line_errors_naming_the_key(line, message):
    with pytest.raises(ConfigError, match=message) as info:
        _parse(line + "\n")
    assert "\n" not in str(info.value) and "line " in str(info.value)


def test_sensor_keys_do_not_change_ids_of_existing_conditions():
    # The thesis' first condition keeps the id it had before the sensor keys existed.
    assert load_sweep("thesis").conditions()[0].id == "e3d3d3c4fdc5a559"
    ideal = _parse("self_noise_dba = \"none\"\nmic_gain_db = 0\n").conditions()[0]
    assert ideal.ideal_sensors and ideal.id == _parse("").conditions()[0].id
    assert _parse("mic_gain_db = 0.5\n").conditions()[0].id != ideal.id


def test_conditions_become_scenes_with_the_drawn_phone():
    sweep = _parse(
        "mic_gain_tol_db = 1.0\nmic_highpass_hz = [80, 120]\nmic_highpass_tol_hz = 10\n"
        "self_noise_dba = 30\nspeech_spl_db = 60\nsnr_band_hz = [100, 7000]\nmic_phase_deg = 2\n"
    )
    c0, c1 = sweep.conditions()[:2]
    s0 = build_scene(c0)
    assert s0.sensors.self_noise_dba == 30.0 and s0.sensors.speech_spl_db == 60.0
    assert s0.snr_band_hz == (100.0, 7000.0)
    assert 70 <= s0.sensors.mics[0].highpass_hz <= 90 and 110 <= s0.sensors.mics[1].highpass_hz <= 130
    assert s0.sensors.mics[1].phase_deg == 2.0
    cols = sensor_columns(c0)
    assert cols["ideal_sensors"] == 0 and cols["mic_gain_db"] == pytest.approx(
        s0.sensors.mics[1].gain_db - s0.sensors.mics[0].gain_db
    )
    assert sensor_columns(c0) == cols  # the same phone for the same seed
    assert build_scene(c1).sensors != s0.sensors  # another seed, another phone
    assert build_scene(_parse("").conditions()[0]).sensors is None  # ideal: no model at all
