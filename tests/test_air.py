"""ISO 9613-1 air absorption coefficients against the standard's tabulated values."""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.errors import ParameterError
from scenesim.room.air import AirAbsorption, air_gain, attenuation_db_per_m

# ISO 9613-2:1996 Table 2 (computed by ISO 9613-1 at exact octave midband frequencies, 101.325 kPa),
# dB/km, octaves 63 Hz .. 8 kHz.
ISO_TABLE_DB_PER_KM = {
    (10.0, 70.0): (0.1, 0.4, 1.0, 1.9, 3.7, 9.7, 32.8, 117),
    (20.0, 70.0): (0.1, 0.3, 1.1, 2.8, 5.0, 9.0, 22.9, 76.6),
    (30.0, 70.0): (0.1, 0.3, 1.0, 3.1, 7.4, 12.7, 23.1, 59.3),
    (15.0, 20.0): (0.3, 0.6, 1.2, 2.7, 8.2, 28.2, 88.8, 202),
    (15.0, 50.0): (0.1, 0.5, 1.2, 2.2, 4.2, 10.8, 36.2, 129),
}
EXACT_MIDBANDS_HZ = 1000.0 * 10.0 ** (np.arange(-12, 10, 3) / 10.0)


@pytest.mark.parametrize(("condition", "table"), list(ISO_TABLE_DB_PER_KM.items()))
def test_matches_iso_table(condition, table):
    """Tolerance: half a unit of the table's last printed digit (0.05 dB/km, or 0.5 dB/km for the
    three-digit entries >= 100), plus 1e-9 for floating point."""
    t, h = condition
    got = attenuation_db_per_m(EXACT_MIDBANDS_HZ, temperature_c=t, humidity_pct=h) * 1000.0
    table = np.asarray(table, dtype=float)
    tol = np.where(table >= 100, 0.5, 0.05) + 1e-9
    assert np.all(np.abs(got - table) <= tol), (got, table)


def test_gain_and_object():
    """Closed form: after t seconds the gain is 10^(-a c t / 20)."""
    g = air_gain(16001, 16000, 0.02, 343.0)
    assert g[0] == 1.0 and g[16000] == pytest.approx(10 ** (-0.02 * 343.0 / 20), rel=1e-12)
    air = AirAbsorption(temperature_c=20.0, humidity_pct=70.0)
    assert air.db_per_m(1000.0) == pytest.approx(attenuation_db_per_m(1000.0, temperature_c=20, humidity_pct=70))
    for kwargs, name in (({"humidity_pct": 120}, "humidity_pct"), ({"temperature_c": float("nan")}, "temperature_c"),
                         ({"pressure_kpa": 0}, "pressure_kpa")):
        with pytest.raises(ParameterError, match=name):
            AirAbsorption(**kwargs)
    with pytest.raises(ParameterError, match="frequency_hz"):
        attenuation_db_per_m([1000.0, -1.0])
