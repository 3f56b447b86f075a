"""Issue 18's tables, measured again: rooms that sound like their RT60.

Sections (``--only`` picks some; each prints a table):

* ``targets``: rooms the calibration never saw (a corridor, one highly absorptive wall, an
  open office), calibrated with and without diffuse scattering, measured at placements drawn
  independently (seeded) by the ISO 3382 chain of :mod:`scenesim.room.iso3382`: speech-octave T30
  and EDT against the target, C50 against its diffuse-field value.
* ``validity``: where the diffuse-field C50 holds (calibrated rooms, scattering 0.5): per room,
  median [min, max] over placements of C50 minus the classical prediction and minus Barron &
  Lee's revised one, the measured share of the reflected energy in the first 50 ms beside the
  model's ``1 - q``, and how much of the broadband C50 miss the 20 Hz high-pass's ringing makes.
* ``pra``: the same rooms against pyroomacoustics' ray tracing (same absorption and
  scattering; T30/EDT per octave, speech-octave mean).
* ``moving``: a 1 kHz and a 4 kHz tone from a talker walking 1 m/s: the largest spectral line
  outside the Doppler band, re the tone, per-image delays vs 50 ms blocks.
* ``hybrid``: hybrid vs full model, per-octave T30 (125 Hz-4 kHz) in a corridor and in a room
  with octave-band absorption and air (scattered), in specular corridor and near-cubic rooms,
  and the hybrid/full speed at RT60 1 s.

Run: ``python -m benchmarks.studies.rooms_check [--only targets validity pra moving hybrid]``.  Timings are
wall clock on a shared machine (quote ``uptime``).
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace

import numpy as np

FS = 16000
ROOMS = {
    "corridor 14x2.2x2.8": ((14.0, 2.2, 2.8), 0.8, None),
    "absorptive wall 7x5x3": ((7.0, 5.0, 3.0), 0.5, (0.9, 0.1, 0.1, 0.1, 0.1, 0.1)),
    "open office 16x12x2.9": ((16.0, 12.0, 2.9), 0.6, (0.15, 0.15, 0.15, 0.15, 0.1, 0.6)),
    "car cabin 2.5x1.5x1.2": ((2.5, 1.5, 1.2), 0.08, None),
}


def _placements(dims, n, seed=5):
    rng = np.random.default_rng(seed)
    d = np.asarray(dims)
    out = []
    for _ in range(n):
        src, mic = rng.uniform(0.15, 0.85, 3) * d, rng.uniform(0.15, 0.85, 3) * d
        if d[2] > 2.0:  # standing talker, seated listener; a cabin keeps the drawn heights
            src[2], mic[2] = 1.6, 1.0
        out.append((src, mic))
    return out


def targets(n_placements: int = 3) -> None:
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.iso3382 import diffuse_field_parameters, room_parameters
    from scenesim.room.render import room_rir

    print("## Unseen rooms: speech-octave T30 / EDT vs target (%), C50 - diffuse-field C50 (dB)")
    print(f"{'room':24s} {'scattering':>10s} {'T30 %':>16s} {'EDT %':>16s} {'C50 dB':>16s}")
    for name, (dims, target, profile) in ROOMS.items():
        for scat in (None, 0.5):
            room = calibrate_room(dims, target, absorption=profile, scattering=scat)
            t30, edt, c50 = [], [], []
            for src, mic in _placements(dims, n_placements):
                h = room_rir(room, src, mic, fs=FS)[0]
                hd = room_rir(room, src, mic, fs=FS, max_order=0, length_s=h.size / FS)[0]
                got = room_parameters(h, FS, h_direct=hd, centers_hz=(500.0, 1000.0, 2000.0))
                want = diffuse_field_parameters(target, float(np.linalg.norm(src - mic)), float(np.prod(dims)))
                t30.append(100 * (got["t_speech_s"] / target - 1))
                edt.append(100 * (got["edt_speech_s"] / target - 1))
                c50.append(got["c50_db"] - want["c50_db"])
            span = lambda v, f: f"{min(v):{f}}..{max(v):{f}}"  # noqa: E731
            print(f"{name:24s} {str(scat):>10s} {span(t30, '+.1f'):>16s} {span(edt, '+.1f'):>16s} {span(c50, '+.2f'):>16s}")


def _c50_parts(room, src, mic):
    """Measured C50 (20 Hz high-pass and raw), early share of the reflected energy, distance."""
    from scenesim.room.iso3382 import clarity_db
    from scenesim.room.render import room_rir

    h = room_rir(room, src, mic, fs=FS)[0]
    hd = room_rir(room, src, mic, fs=FS, max_order=0, length_s=h.size / FS)[0]
    raw = room_rir(room, src, mic, fs=FS, highpass_hz=None)[0]
    n0 = int(np.argmax(np.abs(hd)))
    er = (h - hd) ** 2
    early = float(er[: n0 + int(0.05 * FS)].sum() / er.sum())
    return clarity_db(h, FS, onset=n0), clarity_db(raw, FS, onset=n0), early, float(np.linalg.norm(src - mic))


def _revised_c50(rt60_s, r, volume_m3, c=343.0):
    """Barron & Lee's (1988) revised C50: the reflected energy scaled by exp(-13.82 r / (c T))."""
    from scenesim.room.iso3382 import C50_WINDOW_S, critical_distance_m, diffuse_clarity_db

    # R -> R exp(-k r / c) is r_c -> r_c exp(+k r / (2 c)) in D / R = (r_c / r)^2.
    rc = critical_distance_m(volume_m3, rt60_s) * np.exp(3.0 * np.log(10.0) * r / (c * rt60_s))
    return diffuse_clarity_db(r, rc, rt60_s, C50_WINDOW_S)


def validity(n_placements: int = 12) -> None:
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.iso3382 import diffuse_field_parameters

    print("## C50 - diffuse-field prediction (dB), median [min, max] over placements, calibrated, s 0.5")
    print(f"{'room':24s} {'classical':>22s} {'revised':>22s} {'early share':>12s} {'1 - q':>6s} {'raw - hp':>9s}")
    span = lambda v: f"{np.median(v):+.2f} [{min(v):+.2f}, {max(v):+.2f}]"  # noqa: E731
    for name, (dims, target, profile) in ROOMS.items():
        room = calibrate_room(dims, target, absorption=profile)
        cls, rev, share, hp = [], [], [], []
        for src, mic in _placements(dims, n_placements):
            c50, c50_raw, early, r = _c50_parts(room, src, mic)
            cls.append(c50 - diffuse_field_parameters(target, r, float(np.prod(dims)))["c50_db"])
            rev.append(c50 - _revised_c50(target, r, float(np.prod(dims))))
            share.append(early)
            hp.append(c50_raw - c50)
        q = float(np.exp(-6.0 * np.log(10.0) * 0.05 / target))
        print(f"{name:24s} {span(cls):>22s} {span(rev):>22s} {np.median(share):12.3f} {1 - q:6.3f} "
              f"{np.median(hp):+9.2f}")


def pra(n_placements: int = 1) -> None:
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.crosscheck_scattering import compare_scattering_with_pyroomacoustics

    print("## Scattering 0.5 vs pyroomacoustics ray tracing (same absorption and scattering), mic 0")
    for name, (dims, target, profile) in ROOMS.items():
        room = calibrate_room(dims, target, absorption=profile)
        for src, mic in _placements(dims, n_placements):
            chk = compare_scattering_with_pyroomacoustics(room, src, [mic], fs=FS)
            print(f"{name}: octaves {chk.bands_hz}")
            for label, a, b in (("T30", chk.t30_ours_s, chk.t30_theirs_s), ("EDT", chk.edt_ours_s, chk.edt_theirs_s)):
                print(f"  {label} ours   " + " ".join(f"{v:6.3f}" for v in a))
                print(f"  {label} theirs " + " ".join(f"{v:6.3f}" for v in b))


def moving() -> None:
    from scipy import signal as ss

    from scenesim.room.moving import render_moving_source
    from scenesim.room.shoebox import ShoeBox

    print("## Moving tone (1 m/s, RT60 ~0.3 s): largest line outside f0 (1 +- v/c) +- 6 Hz, dB re tone")
    room = ShoeBox((6.0, 5.0, 3.0), 0.3)
    path, mics = [(1.0, 1.0, 1.5), (1.0, 3.8, 1.5)], [(5.0, 2.5, 1.4), (5.0, 2.52, 1.4)]
    for f0 in (1000.0, 2000.0, 4000.0):
        x = np.sin(2 * np.pi * f0 * np.arange(int(2.8 * FS)) / FS)
        row = []
        for method in ("doppler", "blocks"):
            t0 = time.perf_counter()
            y = render_moving_source(x, room, path, mics, fs=FS, length_s=0.4, method=method)
            dt = time.perf_counter() - t0
            seg = y[0, int(0.6 * FS) : int(2.6 * FS)]
            p = np.abs(np.fft.rfft(seg * ss.windows.blackmanharris(seg.size))) ** 2
            f = np.fft.rfftfreq(seg.size, 1 / FS)
            out = np.abs(f - f0) > f0 / room.c + 6.0
            row.append(f"{method} {10 * np.log10(p[out].max() / p.max()):7.1f} dB ({dt:.1f} s)")
        print(f"  {f0:6.0f} Hz: " + "; ".join(row))


def hybrid() -> None:
    from scenesim.room.air import AirAbsorption
    from scenesim.room.bands import OCTAVE_CENTERS_HZ, octave_rt60
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.render import room_rir
    from scenesim.room.shoebox import ShoeBox
    from scenesim.scene.geometry import MicPair

    centers = OCTAVE_CENTERS_HZ[:6]
    banded = ShoeBox((7.0, 6.0, 3.0), np.array([[0.08, 0.1, 0.15, 0.2, 0.25, 0.3]] * 6), bands_hz=centers,
                     air=AirAbsorption(), scattering=0.5)
    cases = {
        "corridor, calibrated 1 s": calibrate_room((14.0, 2.2, 2.8), 1.0),
        "corridor, specular": ShoeBox((14.0, 2.2, 2.8), 0.1),
        "banded + air, s 0.5": banded,
        "banded + air, specular": replace(banded, scattering=None),
        "~100 m^3 calibrated 1 s": calibrate_room((6.0, 5.5, 3.0), 1.0),
        "~100 m^3 specular 1 s": ShoeBox((6.0, 5.5, 3.0), rt60_s=1.0),
        "6x5x3 specular 1 s": ShoeBox((6.0, 5.0, 3.0), rt60_s=1.0),
    }
    print("## Hybrid vs full (both mics of the 2.14 cm pair): per-octave T30 ratio of mic 0 (125 Hz-4 kHz, "
          "mean over seeds 0-3, the same seed for both: the same scattered field), median wall time of 3 runs "
          "full / hybrid")
    for name, room in cases.items():
        d = np.asarray(room.dims_m)
        src, mic = d * [0.2, 0.4, 0.5], MicPair(tuple(d * [0.75, 0.6, 0.4])).positions_m
        runs = {"fast": [], "hybrid": []}
        for _ in range(3):
            for method in runs:
                t0 = time.perf_counter()
                room_rir(room, src, mic, fs=FS, method=method)
                runs[method].append(time.perf_counter() - t0)
        t_full, t_hyb = (statistics.median(runs[m]) for m in ("fast", "hybrid"))
        ratio = np.mean([octave_rt60(room_rir(room, src, mic, fs=FS, method="hybrid", seed=s)[0], FS, centers)
                         / octave_rt60(room_rir(room, src, mic, fs=FS, method="fast", seed=s)[0], FS, centers)
                         for s in range(4)], axis=0)
        print(f"  {name:26s} " + " ".join(f"{v:5.3f}" for v in ratio)
              + f"   {t_full:6.2f} s / {t_hyb:5.2f} s = {t_full / t_hyb:5.1f}x")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=("targets", "validity", "pra", "moving", "hybrid"),
                    default=("targets", "validity", "pra", "moving", "hybrid"))
    args = ap.parse_args(argv)
    for name in args.only:
        globals()[name]()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
