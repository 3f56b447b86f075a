"""Hybrid renderer in scattered rooms: per-octave decay of the full model, diffuse coherence."""

import numpy as np
import pytest
from scipy import signal

from scenesim.room.air import AirAbsorption
from scenesim.room.bands import OCTAVE_CENTERS_HZ, octave_rt60
from scenesim.room.calibration import calibrate_room
from scenesim.room.render import room_rir
from scenesim.room.shoebox import ShoeBox

FS = 16000
CENTERS = OCTAVE_CENTERS_HZ[:6]  # 125 Hz-4 kHz


def _rooms():
    banded = ShoeBox((7.0, 6.0, 3.0), np.array([[0.08, 0.1, 0.15, 0.2, 0.25, 0.3]] * 6), bands_hz=CENTERS,
                     air=AirAbsorption(), scattering=0.5)
    return {"corridor": calibrate_room((14.0, 2.2, 2.8), 0.7), "banded + air": banded}


@pytest.mark.parametrize("name", ["corridor", "banded + air"])
def test_hybrid_octave_t30_matches_the_full_model(name):
    """Oracle: the full model (every specular image + the same scattered field).  Per octave
    125 Hz-4 kHz the hybrid's T30 is within 10 % of the full model's (measured within 0.7 %;
    the specular-only hybrid missed by 18-37 % in these rooms, issue 18)."""
    room = _rooms()[name]
    d = np.asarray(room.dims_m)
    src, mic = d * [0.2, 0.4, 0.5], d * [0.75, 0.6, 0.4]
    full = room_rir(room, src, mic, fs=FS, method="fast")[0]
    hyb = room_rir(room, src, mic, fs=FS, method="hybrid")[0]
    np.testing.assert_allclose(octave_rt60(hyb, FS, CENTERS), octave_rt60(full, FS, CENTERS), rtol=0.10)


def test_late_coherence_is_the_diffuse_fields_at_several_frequencies():
    """Oracle: the diffuse-field coherence sinc(2 f d / c) (Cook et al. 1955) of two mics 10 cm
    apart: the real coherence of the hybrid RIRs' late parts (after 0.1 s, 40 source
    placements pooled) at 250 Hz-4 kHz, where it runs from 0.95 through 0 to -0.2, within 0.1."""
    room = calibrate_room((6.0, 5.0, 3.0), 0.6)
    mics = np.array([[4.0, 2.5, 1.3], [4.1, 2.5, 1.3]])
    rng = np.random.default_rng(3)
    sxy = sxx = syy = 0.0
    for _ in range(40):
        src = rng.uniform([0.5, 0.5, 1.0], [2.5, 4.5, 2.0])
        h = room_rir(room, src, mics, fs=FS, method="hybrid")[:, int(0.1 * FS):]
        f, p = signal.csd(h[0], h[1], FS, nperseg=512)
        sxy = sxy + p
        sxx = sxx + signal.welch(h[0], FS, nperseg=512)[1]
        syy = syy + signal.welch(h[1], FS, nperseg=512)[1]
    coh = np.real(sxy) / np.sqrt(sxx * syy)
    for fc in (250.0, 500.0, 1000.0, 2000.0, 4000.0):
        k = int(np.argmin(np.abs(f - fc)))
        assert coh[k] == pytest.approx(np.sinc(2 * f[k] * 0.1 / room.c), abs=0.1), fc
