"""Octave-band materials and air absorption against pyroomacoustics 0.10.1 (outside implementation).

Same image set (max_order 15), same per-wall per-octave absorption, same air coefficients;
the filter banks differ by design (Antoni 512-tap vs our complementary zero-phase bank).
Measured (6 x 5 x 3 m, 16 kHz): rel L2 5e-3 (bands), 7e-3 (air), 1.0e-2 (both); octave
energy within 0.07 dB; octave T30 within 1.0 %.  Tolerances: rel L2 2e-2, 0.15 dB, 2 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.room.air import AirAbsorption, attenuation_db_per_m
from scenesim.room.bands import OCTAVE_CENTERS_HZ, exact_midband_hz
from scenesim.room.shoebox import ShoeBox

pytest.importorskip("pyroomacoustics")

from scenesim.room.crosscheck_bands import (  # noqa: E402 - needs pyroomacoustics
    compare_bands_with_pyroomacoustics,
    pyroomacoustics_air_table,
)

TABLE = np.array([
    [0.10, 0.15, 0.25, 0.35, 0.45, 0.55, 0.60],
    [0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08],
    [0.30, 0.20, 0.15, 0.10, 0.10, 0.10, 0.10],
    [0.05] * 7,
    [0.20] * 7,
    [0.60, 0.50, 0.40, 0.30, 0.30, 0.30, 0.30],
])
SRC, MICS = (1.2, 1.7, 1.4), [(4.1, 3.0, 1.5), (4.12, 3.0, 1.5)]


@pytest.mark.parametrize(
    "room",
    [
        ShoeBox((6, 5, 3), TABLE, bands_hz=OCTAVE_CENTERS_HZ),
        ShoeBox((6, 5, 3), 0.15, air=AirAbsorption(temperature_c=20, humidity_pct=40)),
        ShoeBox((6, 5, 3), TABLE, bands_hz=OCTAVE_CENTERS_HZ, air=AirAbsorption(temperature_c=20, humidity_pct=40)),
    ],
    ids=["bands", "air", "bands+air"],
)
def test_agrees_with_pyroomacoustics(room):
    check = compare_bands_with_pyroomacoustics(room, SRC, MICS, fs=16000, max_order=15)
    assert max(check.rel_l2) < 2e-2
    assert check.max_band_energy_db < 0.15
    assert check.max_t30_rel_diff < 0.02
    assert len(check.bands_hz) == 7


def test_air_effect_is_seen_by_the_crosscheck():
    """The air case must differ from the air-free room by far more than the tolerance at 8 kHz
    (so the comparison above can fail): over 0.5 dB of octave energy here."""
    with_air = ShoeBox((6, 5, 3), 0.15, air=AirAbsorption(temperature_c=20, humidity_pct=40))
    from scenesim.room.crosscheck_bands import pyroomacoustics_band_rir
    from scenesim.room.render import room_rir

    theirs = pyroomacoustics_band_rir(with_air, SRC, MICS, fs=16000, max_order=15)
    ours_no_air = room_rir(ShoeBox((6, 5, 3), 0.15), SRC, MICS, fs=16000, max_order=15,
                           length_s=theirs.shape[1] / 16000, highpass_hz=None)
    from scenesim.room.bands import octave_filter

    n = min(theirs.shape[1], ours_no_air.shape[1])
    e = [np.sum(octave_filter(x[0, :n], 16000, 8000.0) ** 2) for x in (ours_no_air, theirs)]
    assert 10 * np.log10(e[0] / e[1]) > 0.5


def test_our_iso_coefficients_vs_pyroomacoustics_table():
    """pyroomacoustics ships a coarse table (one row per 10/20 C and 30-50/50-70/70-90 % class);
    ISO 9613-1 at 20 C / 40 % lies within 30 % of it up to 1 kHz and above it at 2-8 kHz
    (ours 11.2/36.1/128 dB/km vs its 8.3/25.2/88.2).  Documented, not a bug of either."""
    ours = attenuation_db_per_m(exact_midband_hz(OCTAVE_CENTERS_HZ), temperature_c=20, humidity_pct=40)
    theirs = pyroomacoustics_air_table(20, 40)
    np.testing.assert_allclose(ours[:4], theirs[:4], rtol=0.3)
    assert np.all(ours[4:] > theirs[4:])
