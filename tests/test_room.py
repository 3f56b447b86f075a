"""ShoeBox: validation, derived values, RT60-driven absorption and closed-loop calibration."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.ism import image_source_rir
from scenesim.room import (
    CALIBRATION_FS,
    ShoeBox,
    _calibrated_absorption_cached,
    default_calibration_positions,
)
from scenesim.rt60 import eyring_rt60, measure_rt60, sabine_rt60


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


@pytest.mark.parametrize("dims", [(6.0, 5.0, 3.0), (4.0, 3.5, 2.7)])
@pytest.mark.parametrize("rt60", [0.2, 0.4, 0.6, 1.0])
def test_calibrated_rt60_within_5_percent(dims, rt60):
    """Closed loop: the T30 measured (Schroeder, -5..-35 dB) on a RIR rendered again (exact
    renderer, longer) at the calibration placement is within 5 % of the target (issue target; the
    loop stops at 1 %).  Not an independent check -- same placement, same estimator; that one is
    tests/test_rt60_independent.py.  Sabine alone misses by up to ~50 % here, so the test can fail."""
    room = ShoeBox(dims, rt60_s=rt60, rt60_method="calibrated")
    src, mic = default_calibration_positions(dims)
    h = image_source_rir(room, src, mic, fs=CALIBRATION_FS, length_s=1.6 * rt60 + 0.1)[0]
    assert measure_rt60(h, CALIBRATION_FS, method="T30") == pytest.approx(rt60, rel=0.05)


def test_calibration_is_cached():
    _calibrated_absorption_cached.cache_clear()
    a = ShoeBox((5.0, 4.0, 3.0), rt60_s=0.3, rt60_method="calibrated")
    b = ShoeBox((5.0, 4.0, 3.0), rt60_s=0.3, rt60_method="calibrated")
    info = _calibrated_absorption_cached.cache_info()
    assert (info.misses, info.hits) == (1, 1)
    np.testing.assert_array_equal(a.wall_absorption, b.wall_absorption)


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
        (((6, 5, 3), 0.3), {"c": 0.0}, "c"),
        (((6, 5, 3), 0.3), {"min_wall_distance_m": -0.1}, "min_wall_distance_m"),
    ],
)
def test_bad_input_raises(args, kwargs, name):
    with pytest.raises(ParameterError, match=name):
        ShoeBox(*args, **kwargs)
