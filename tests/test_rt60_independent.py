"""The RT60 calibration checked independently: other positions and another T30 estimator.

``rt60_method="calibrated"`` adjusts absorption until *our* T30 (scenesim.rt60) of *one*
RIR (the calibration placement) hits the target, so re-measuring that RIR the same way
only checks the loop's arithmetic.  Here (issue 11) the RIRs are rendered at three other
source/mic placements and measured with pyroomacoustics' ``experimental.measure_rt60``
(its own Schroeder integration and -5..-35 dB fit).  Measured: every T30 within 2 % of the
target; the test allows 5 % (the calibration's acceptance limit).  Sabine's absorption
misses by 20-50 % in these rooms, so a calibration that fell back to it would fail.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenesim.ism import image_source_rir
from scenesim.room import ShoeBox, default_calibration_positions

pra = pytest.importorskip("pyroomacoustics")

FS = 16000
PLACEMENTS = [((1.0, 1.2, 1.5), (3.6, 2.7, 1.1)), ((3.5, 1.0, 2.2), (2.0, 3.0, 1.3)), ((3.1, 3.0, 0.8), (1.2, 0.9, 2.1))]


@pytest.mark.parametrize("dims, rt60", [((6.0, 5.0, 3.0), 0.4), ((6.0, 5.0, 3.0), 0.8), ((4.0, 3.5, 2.7), 0.6)])
def test_calibrated_room_hits_rt60_at_other_positions_by_another_estimator(dims, rt60):
    room = ShoeBox(dims, rt60_s=rt60, rt60_method="calibrated")
    cal_src, cal_mic = default_calibration_positions(dims)
    for src, mic in PLACEMENTS:
        assert not np.allclose(src, cal_src) and not np.allclose(mic, cal_mic)  # really elsewhere
        h = image_source_rir(room, src, mic, fs=FS, length_s=1.6 * rt60 + 0.1)[0]
        t30 = pra.experimental.measure_rt60(h, fs=FS, decay_db=30)
        assert t30 == pytest.approx(rt60, rel=0.05), (src, mic)


def test_sabine_misses_in_the_same_rooms_so_the_test_can_fail():
    room = ShoeBox((6.0, 5.0, 3.0), rt60_s=0.8, rt60_method="sabine")
    src, mic = PLACEMENTS[0]
    h = image_source_rir(room, src, mic, fs=FS, length_s=1.6 * 0.8 + 0.1)[0]
    assert pra.experimental.measure_rt60(h, fs=FS, decay_db=30) > 1.15 * 0.8
