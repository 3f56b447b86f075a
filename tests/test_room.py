"""ShoeBox: validation, derived values, RT60-driven absorption and closed-loop calibration."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.room.rt60 import eyring_rt60, sabine_rt60
from scenesim.room.shoebox import ShoeBox


def test_derived_values():
    """Oracles: geometry by hand and b = sqrt(1 - alpha)."""
    alpha = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
    room = ShoeBox((6.0, 5.0, 3.0), alpha)
    assert room.volume_m3 == 90.0
    assert room.surface_m2 == 126.0
    np.testing.assert_array_equal(room.wall_absorption, alpha)
    np.testing.assert_allclose(room.reflection, np.sqrt(1 - np.array(alpha)), rtol=1e-15)
    assert room.sabine_rt60_s == sabine_rt60((6, 5, 3), alpha)
    assert room.eyring_rt60_s == eyring_rt60((6, 5, 3), alpha)
    scalar = ShoeBox([6, 5, 3], 0.25)
    np.testing.assert_array_equal(scalar.wall_absorption, np.full(6, 0.25))
    assert scalar.dims_m == (6.0, 5.0, 3.0)


def test_frozen_and_hashable():
    room = ShoeBox((6.0, 5.0, 3.0), 0.3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        room.c = 340.0  # type: ignore[misc]
    assert hash(room) == hash(ShoeBox((6, 5, 3), 0.3)) and room == ShoeBox((6, 5, 3), 0.3)


@pytest.mark.parametrize("rt60", [0.2, 0.5, 1.2])
def test_rt60_sabine_and_eyring_hit_their_formula(rt60):
    """Oracle: the forward formulas. 1e-12 relative."""
    assert ShoeBox((6, 5, 3), rt60_s=rt60).sabine_rt60_s == pytest.approx(rt60, rel=1e-12)
    eyr = ShoeBox((6, 5, 3), rt60_s=rt60, rt60_method="eyring")
    assert eyr.eyring_rt60_s == pytest.approx(rt60, rel=1e-12)
    assert eyr.nominal_rt60_s == rt60


# Closed-loop calibration (ShoeBox(rt60_method="calibrated") and calibrate_room) is tested in
# tests/test_calibration.py, with an independent estimator at other placements.


def test_check_inside():
    room = ShoeBox((4.0, 3.0, 2.5), 0.3, min_wall_distance_m=0.2)
    np.testing.assert_array_equal(room.check_inside((1, 1, 1)), [1.0, 1.0, 1.0])
    room.check_inside((0.2, 2.8, 2.3))  # exactly at the minimum distance is allowed
    with pytest.raises(ParameterError, match="talker"):
        room.check_inside((0.1, 1, 1), name="talker")
    with pytest.raises(ParameterError, match="position"):
        room.check_inside((5.0, 1, 1))
    with pytest.raises(ParameterError, match="position"):
        room.check_inside((1.0, 1.0))
    with pytest.raises(ParameterError, match="position"):
        room.check_inside((1.0, np.nan, 1.0))


@pytest.mark.parametrize(
    ("args", "kwargs", "name"),
    [
        (((6, 5, -3), 0.3), {}, "dims_m"),
        (((6, 5), 0.3), {}, "dims_m"),
        (((6, 5, 3), 0.0), {}, "absorption"),
        (((6, 5, 3), 1.5), {}, "absorption"),
        (((6, 5, 3), (0.3,) * 5), {}, "absorption"),
        (((6, 5, 3), (0.3, 0.3, 0.3, 0.3, 0.3, -0.1)), {}, "absorption"),
        (((6, 5, 3),), {}, "absorption"),  # neither
        (((6, 5, 3), 0.3), {"rt60_s": 0.5}, "absorption"),  # both
        (((6, 5, 3),), {"rt60_s": 0.05}, "rt60_s"),  # Sabine alpha > 1
        (((6, 5, 3),), {"rt60_s": 0.05, "rt60_method": "calibrated"}, "rt60_s"),
        (((6, 5, 3),), {"rt60_s": -1.0}, "rt60_s"),
        (((6, 5, 3),), {"rt60_s": 0.5, "rt60_method": "norris"}, "rt60_method"),
        (((6, 5, 3), 0.3), {"rt60_s": 0.5, "rt60_method": "sabine"}, "absorption"),  # profile: calibrated only
        (((6, 5, 3), (0.1, 0.2)), {"bands_hz": (500, 1000, 2000)}, "absorption"),
        (((6, 5, 3), 0.3), {"bands_hz": (1000, 500)}, "bands_hz"),
        (((6, 5, 3), 0.3), {"air": "humid"}, "air"),
        (((6, 5, 3), 0.3), {"target_rt60_s": -1.0}, "target_rt60_s"),
        (((6, 5, 3), 0.3), {"c": 0.0}, "c"),
        (((6, 5, 3), 0.3), {"min_wall_distance_m": -0.1}, "min_wall_distance_m"),
    ],
)
def test_bad_input_raises(args, kwargs, name):
    with pytest.raises(ParameterError, match=name):
        ShoeBox(*args, **kwargs)


def test_banded_room_table_and_band_rooms():
    """Oracle: broadcasting rules written out by hand; Sabine per band from the flat formula."""
    room = ShoeBox((6, 5, 3), (0.1, 0.2, 0.4), bands_hz=(500, 1000, 2000))
    np.testing.assert_array_equal(room.wall_absorption, np.tile([0.1, 0.2, 0.4], (6, 1)))
    per_wall = ShoeBox((6, 5, 3), (0.1, 0.2, 0.3, 0.4, 0.5, 0.6), bands_hz=(500, 1000))
    np.testing.assert_array_equal(per_wall.wall_absorption[:, 1], [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert room.band_room(2) == ShoeBox((6, 5, 3), (0.4,) * 6)
    np.testing.assert_allclose(room.sabine_rt60_s, [sabine_rt60((6, 5, 3), a) for a in (0.1, 0.2, 0.4)], rtol=1e-15)
    assert room.nominal_rt60_s == pytest.approx(sabine_rt60((6, 5, 3), 0.1), rel=1e-15)
    assert hash(room) == hash(ShoeBox((6, 5, 3), (0.1, 0.2, 0.4), bands_hz=(500, 1000, 2000)))
    with pytest.raises(ParameterError, match="room"):
        room.reflection  # noqa: B018 - a banded room cannot go through one image-source render
    with pytest.raises(ParameterError, match="band"):
        room.band_room(3)
