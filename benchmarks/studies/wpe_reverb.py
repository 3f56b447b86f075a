"""Why WPE's C50 and SINR gains look small in the ``reverb`` rows: two ways to score one output.

    python -m benchmarks.studies.wpe_reverb --data-dir ../shared/data [--rt60 0.6 0.9] [--seeds 3] [--seconds 8]

A scene like the ``reverb`` preset's (5 x 4 x 2.8 m, Sabine RT60 (not calibrated), talker 1 m at 45 deg,
point noise 1.5 m at 200 deg at ``--snr`` dB, ideal sensors; CMU ARCTIC speech, seeded noise).  Each
replayable system is scored two ways:

* **parts replayed** (what ``benchmarks.metrics.reverb`` stores): the input's direct+early and
  late speech images go through the frozen filter one at a time; ``C50 = |early out|^2 / |late
  out|^2``, ``SINR = |early out|^2 / |late out + noise out|^2``.  WPE subtracts from each frame a
  prediction made from the frames 24..104 ms before it, and those past frames are mostly
  *direct + early* speech: replaying the early part alone yields ``early - (prediction of the
  late reverberation)``, replaying the late part alone leaves it nearly intact.  The
  cancellation happens between the parts, so this split books it as a distortion of the target.
* **effective RIR**: the speech RIR itself (both mics, placed 1, 2.5 and 4 s into a silent
  signal: an adaptive beamformer changes over time) is replayed through the same frozen
  filter, giving the talker-to-output response; its energy before and after the same cut
  (direct arrival + 50 ms), 100 Hz-7 kHz, gives ``c50_eff`` (ISO 3382's C50 of the whole
  system, frequencies weighted alike), and the dry speech convolved with its two pieces gives
  the output's own early and late speech: ``c50_eff_speech`` (their ratio, weighted by the
  speech spectrum as ``c50_parts`` is) and ``sinr_eff`` (noise replayed as above); powers are
  averaged over the probes.  ``noise_out``: the replayed noise's level re the input's (dB).

SRMR (non-intrusive, of the output itself) needs no split.  Mean over seeds (the talker's
utterance and the noise change with the seed).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.signal import oaconvolve

from benchmarks.metrics import speech as M
from benchmarks.metrics.srmr import srmr
from scenesim.audio import read_audio
from scenesim.room.reverb_parts import speech_parts
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import NoiseSource, Scene, SourcePlacement, render_images
from scenesim.scene.geometry import MicPair

FS = 16000
SYSTEMS = ("passthrough", "wpe", "eb-robust", "wpe-eb-robust")


def _speech(data_dir: Path, seed: int, seconds: float) -> np.ndarray:
    files = sorted((data_dir / "speech").glob("*.wav"))
    parts, n = [], int(seconds * FS)
    k = seed
    while sum(p.size for p in parts) < n:
        parts.append(read_audio(files[k % len(files)], fs=FS)[0][0])
        k += 1
    s = np.concatenate(parts)[:n]
    return 0.05 * s / np.sqrt(np.mean(s**2))


def _scene(rt60: float, seed: int, s: np.ndarray, snr_db: float = 10.0):
    scene = Scene(fs=FS, pair=MicPair((2.0, 1.8, 0.9), axis_azimuth_deg=90.0, spacing_m=0.0214),
                  room=ShoeBox((5.0, 4.0, 2.8), rt60_s=rt60), speech=SourcePlacement(45.0, 1.0),
                  noises=(NoiseSource(azimuth_deg=200.0, distance_m=1.5),), far_field=False,
                  reference="early50", snr_db=snr_db)
    noise = np.random.default_rng(seed).standard_normal(s.size)
    images = render_images(scene, s, [noise])
    return images, speech_parts(images, s)


def _score(name: str, images, parts, s: np.ndarray) -> dict:
    import enhancers

    rendered = images.mix()
    x = np.asarray(rendered.mixture, dtype=np.float64)
    e = enhancers.make(name)
    result = e.process(x, FS)
    noise = np.asarray(rendered.noise_image, dtype=np.float64)
    # Output channel 0 of every replayed component (latency 0 for these systems).
    d, early, late, n_o = (result.replay(c)[0] for c in (parts.direct, parts.early, parts.late, noise))
    h = np.asarray(images.rirs["speech"], dtype=np.float64)
    head, tail = _effective_rir_pieces(result, x, h, parts.cut_sample)
    early_eff = sum(oaconvolve(s, p)[:s.size] ** 2 for p in head) / len(head)  # mean power over probes
    late_eff = [oaconvolve(s, p)[:s.size] for p in tail]
    skip = FS  # the first second: WPE's and the beamformer's start-up
    sl = slice(skip, None)
    late_pow = np.mean([np.sum(v[sl] ** 2) for v in late_eff])
    noise_pow = np.sum(n_o[sl] ** 2)
    late_noise_pow = np.mean([np.sum((v[sl] + n_o[sl]) ** 2) for v in late_eff])
    return {
        "srmr": srmr(result.output[0], FS),
        "c50_parts": M.snr_db((d + early)[sl], late[sl]),
        "sinr_parts": M.snr_db((d + early)[sl], (late + n_o)[sl]),
        "c50_eff": 10 * np.log10(sum(map(_band_energy, head)) / sum(map(_band_energy, tail))),
        "c50_eff_speech": 10 * np.log10(np.sum(early_eff[sl]) / late_pow),
        "sinr_eff": 10 * np.log10(np.sum(early_eff[sl]) / late_noise_pow),
        "noise_out": 10 * np.log10(noise_pow / np.sum(noise[0][sl] ** 2)),
    }


def _effective_rir_pieces(result, x: np.ndarray, h: np.ndarray, cut: int):
    """Channel 0 of the speech RIR replayed at 1, 2.5 and 4 s (an adaptive system changes over
    time), each split at ``cut``: ``([head], [tail])``."""
    heads, tails = [], []
    for t0 in (FS, 5 * FS // 2, 4 * FS):
        if t0 + h.shape[1] > x.shape[1]:
            break
        probe = np.zeros_like(x)
        probe[:, t0:t0 + h.shape[1]] = h
        h_eff = result.replay(probe)[0][t0:t0 + h.shape[1]]
        heads.append(np.where(np.arange(h_eff.size) < cut, h_eff, 0.0))
        tails.append(np.where(np.arange(h_eff.size) >= cut, h_eff, 0.0))
    return heads, tails


def _band_energy(p: np.ndarray, lo: float = 100.0, hi: float = 7000.0) -> float:
    """Energy of ``p`` between ``lo`` and ``hi`` Hz (flat weighting: ISO 3382's C50 over the band)."""
    spec = np.abs(np.fft.rfft(p)) ** 2
    f = np.fft.rfftfreq(p.size, 1.0 / FS)
    return float(np.sum(spec[(f >= lo) & (f <= hi)]))

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, required=True, help="folder with speech/ (CMU ARCTIC)")
    ap.add_argument("--rt60", type=float, nargs="+", default=[0.6, 0.9])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--systems", nargs="+", default=list(SYSTEMS))
    ap.add_argument("--snr", type=float, default=10.0, help="point noise level re the speech (dB)")
    args = ap.parse_args(argv)
    keys = ("srmr", "c50_parts", "c50_eff", "c50_eff_speech", "sinr_parts", "sinr_eff", "noise_out")
    print(f"WPE scored two ways, mean over {args.seeds} seeds, {args.seconds:g} s of CMU ARCTIC speech, "
          f"point noise at {args.snr:g} dB")
    print("| RT60 (s) | system | " + " | ".join(keys) + " |")
    print("| ---: | --- |" + " ---: |" * len(keys))
    for rt60 in args.rt60:
        rows = {name: [] for name in args.systems}
        for seed in range(args.seeds):
            s = _speech(args.data_dir, seed, args.seconds)
            images, parts = _scene(rt60, seed, s, args.snr)
            for name in args.systems:
                rows[name].append(_score(name, images, parts, s))
        for name in args.systems:
            mean = {k: float(np.mean([r[k] for r in rows[name]])) for k in keys}
            print(f"| {rt60:g} | {name} | " + " | ".join(f"{mean[k]:.2f}" for k in keys) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
