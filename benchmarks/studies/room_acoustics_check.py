"""Room acoustics a study can trust: how well calibrated rooms decay as asked (issue 10).

Two tables, printed for the current code:

1. Flat absorption, scalar target (``calibrate_room(dims, rt60)``, the path
   ``ShoeBox(rt60_method="calibrated")`` takes): the independent check -- 4 seeded random
   placements (not the loop's), octaves 500 Hz/1 kHz/2 kHz by a causal 4th-order Butterworth,
   T30 by pyroomacoustics' ``experimental.measure_rt60(decay_db=30)``; the error of their mean
   ("speech") and of the 20 Hz high-passed broadband T30, relative to the target.
2. Per-band targets (``calibrate_room(dims, rt60_per_band, bands_hz=OCTAVE_CENTERS_HZ)``):
   octave T30 (our estimator) of the *combined* RIR, mean over the 3 calibration placements and
   over 6 random other placements, error per octave.

Run: ``python -m benchmarks.studies.room_acoustics_check`` (about 2 minutes on a loaded 2-core box).
To get the "before" column of table 1, run the same function against an older checkout's
``ShoeBox(dims, rt60_s=t, rt60_method="calibrated")``.
"""

from __future__ import annotations

import time

import numpy as np
from scipy import signal

FS = 16000
FLAT_ROOMS = [((6, 5, 3), 0.4), ((6, 5, 3), 0.6), ((6, 5, 3), 1.0), ((4, 3.5, 2.7), 0.5), ((4, 3.5, 2.7), 1.0),
              ((8, 6, 3.2), 0.8), ((8, 6, 3.2), 1.5), ((12, 3, 2.5), 1.0), ((5, 4, 2.8), 2.0)]
BAND_CASES = [((6, 5, 3), (0.8, 0.7, 0.6, 0.55, 0.5, 0.45, 0.4), None),
              ((4, 3.5, 2.7), (1.2, 1.0, 0.9, 0.8, 0.7, 0.6, 0.5), None),
              ((8, 6, 3.2), (0.5,) * 7, np.outer([1, 1, 0.8, 0.8, 0.5, 1.5], np.ones(7)) * 0.2)]


def independent_errors(room, t, *, n_placements=4, seed=7):
    """(octave 500/1k/2k errors, speech-mean error, 20 Hz high-passed broadband error), relative."""
    import pyroomacoustics.experimental as pe

    from scenesim.room.ism import image_source_rir

    rng = np.random.default_rng(seed)
    d = np.asarray(room.dims_m, dtype=float)
    vals = []
    for _ in range(n_placements):
        src, mic = rng.uniform(0.15 * d, 0.85 * d), rng.uniform(0.15 * d, 0.85 * d)
        h = image_source_rir(room, src, mic, fs=FS, length_s=1.3 * t + 0.05)[0]
        row = []
        for fc in (500, 1000, 2000):
            sos = signal.butter(4, [fc / np.sqrt(2), fc * np.sqrt(2)], btype="bandpass", fs=FS, output="sos")
            row.append(pe.measure_rt60(signal.sosfilt(sos, h), fs=FS, decay_db=30))
        hp = signal.sosfilt(signal.butter(2, 20, "highpass", fs=FS, output="sos"), h)
        row.append(pe.measure_rt60(hp, fs=FS, decay_db=30))
        vals.append(row)
    v = np.mean(vals, axis=0) / t - 1.0
    return v[:3], float(np.mean(v[:3])), float(v[3])


def main() -> None:
    from scenesim.room.bands import OCTAVE_CENTERS_HZ, octave_rt60
    from scenesim.room.calibration import (
        CALIBRATION_PLACEMENTS,
        calibrate_room,
        default_calibration_positions,
    )
    from scenesim.room.render import room_rir

    print("1. flat calibration, independent check (pyroomacoustics measure_rt60, 4 other placements)")
    print("room            RT60  | 500 Hz  1 kHz  2 kHz | speech mean | HP20 broadband | calibration s")
    for dims, t in FLAT_ROOMS:
        t0 = time.perf_counter()
        room = calibrate_room(dims, t)
        dt = time.perf_counter() - t0
        octs, speech, hp = independent_errors(room, t)
        print(f"{str(dims):15s} {t:4.1f}  | " + " ".join(f"{100 * e:+6.1f}" for e in octs)
              + f" | {100 * speech:+6.1f} %    | {100 * hp:+6.1f} %       | {dt:5.1f}")
    print("\n2. per-band calibration: octave T30 error (%) of the combined RIR, 125 Hz..4 kHz")
    for dims, targets, profile in BAND_CASES:
        tg = np.asarray(targets)
        t0 = time.perf_counter()
        room = calibrate_room(dims, tg, absorption=profile, bands_hz=OCTAVE_CENTERS_HZ, fs=FS)
        dt = time.perf_counter() - t0
        length = 1.2 * tg.max() + 0.05
        own = [octave_rt60(room_rir(room, *default_calibration_positions(dims, k), fs=FS, length_s=length)[0],
                           FS, OCTAVE_CENTERS_HZ[:6]) for k in range(len(CALIBRATION_PLACEMENTS))]
        rng = np.random.default_rng(3)
        d = np.asarray(dims, dtype=float)
        other = [octave_rt60(room_rir(room, rng.uniform(0.15 * d, 0.85 * d), rng.uniform(0.15 * d, 0.85 * d),
                                      fs=FS, length_s=length)[0], FS, OCTAVE_CENTERS_HZ[:6]) for _ in range(6)]
        kind = "profile" if profile is not None else "uniform"
        print(f"{dims} targets {list(targets)} ({kind}), calibration {dt:.1f} s")
        print("  calibration placements: " + " ".join(f"{100 * e:+5.1f}" for e in np.mean(own, 0) / tg[:6] - 1))
        print("  6 other placements:     " + " ".join(f"{100 * e:+5.1f}" for e in np.mean(other, 0) / tg[:6] - 1))


if __name__ == "__main__":
    main()
