"""Issue 12 targets: null depth, mismatch robustness, self-noise amplification, real-time factor.

    python -m benchmarks.studies.robust_eb [--seconds 20] [--settle-s 8] [--runs 5] [--skip-rtf]

Prints four markdown tables:

1. Null depth (ideal mics) of one far-field plane wave of white noise at 120/135/150 deg:
   output power of a look-direction (0 deg) white plane wave replayed through the adapted
   beamformer over the interferer's output power, second half of 4 s (target >= 30 dB for
   ``eb-subband``).
2. SNR-I (replay, algorithms.md section 8) with speech (built-in artificial voice) from 45 deg
   far field and babble from one far-field source at 135 or 240 deg or a diffuse field
   (sinc coherence), or synthesized wind with Corcos coherence (5 m/s), 5 dB SNR at the front mic; ideal mics vs the rear mic times
   ``10^(1/20) e^{j 5 deg}``.  Scored after ``--settle-s`` seconds (the convergence time
   we allow: calibration time constant 1 s plus the speech-gated pauses); target:
   ``eb-robust`` within 2 dB of its ideal-sensor value, ``eb`` losing > 8 dB.
3. Broadband amplification of spatially white noise relative to the look direction:
   ``10 log10((P_out(white) / P_in(white)) / (P_out(look) / P_in(look)))`` with a white plane
   wave from 0 deg and independent white noise at both mics (20 dB below it) processed
   together; replayed separately, second half (target <= 6 dB for ``eb-robust``; the fixed
   cardioid: 10.8 dB).
4. Batch real-time factor of ``eb-robust-ss`` on 10 s of 2-channel 16 kHz audio, median of
   ``--runs`` runs with the numpy rfft/irfft peer of :mod:`benchmarks.perf.enhancer_rtf`
   (target <= 0.01).

Mismatched microphones come from a local helper (rear channel times ``r`` via rfft), not
from a scene sensor model.
"""

from __future__ import annotations

import argparse

import numpy as np

import enhancers
from benchmarks.perf.enhancer_rtf import measure
from data_recipes.artificial_voice import artificial_voice
from data_recipes.noise_synthesis import synthesize_noise
from scenesim.scene.freefield import plane_wave
from scenesim.scene.geometry import MicPair
from scenesim.scene.noise_fields import diffuse_noise, wind_noise

FS = 16000
PAIR = MicPair()


def rear_mismatch(x: np.ndarray, *, gain_db: float, phase_deg: float) -> np.ndarray:
    """Rear channel times ``10^(g/20) e^{j phi}`` at positive frequencies (DC/Nyquist: gain only)."""
    n = x.shape[-1]
    X = np.fft.rfft(x, axis=-1)
    r = np.full(X.shape[-1], 10 ** (gain_db / 20) * np.exp(1j * np.radians(phase_deg)))
    r[0] = r[-1] = 10 ** (gain_db / 20)
    X[1] = X[1] * r
    return np.fft.irfft(X, n=n, axis=-1)


def _power(x, start):
    return float(np.mean(x[..., start:] ** 2))


def null_depths(seconds: float = 4.0, seed: int = 1) -> list[tuple]:
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    rows = []
    for theta in (120, 135, 150):
        x = plane_wave(rng.standard_normal(n), PAIR, azimuth_deg=theta, fs=FS)
        look = plane_wave(rng.standard_normal(n), PAIR, azimuth_deg=0, fs=FS)
        row = [theta]
        for name in ("eb", "eb-subband"):
            r = enhancers.make(name).process(x, FS)
            row.append(10 * np.log10(_power(r.replay(look), n // 2) / _power(r.output, n // 2)))
        rows.append(tuple(row))
    return rows


def _scene(noise_kind: str, seconds: float, seed: int):
    """Speech and noise images ``(2, n)`` (noise scaled for 5 dB SNR at the front mic)."""
    n = int(seconds * FS)
    speech, _ = artificial_voice(seconds, fs=FS, seed=seed)
    s = plane_wave(speech, PAIR, azimuth_deg=45, fs=FS)
    rng = np.random.default_rng(seed + 100)
    if noise_kind == "diffuse":
        src = synthesize_noise("babble", n, fs=FS, rng=rng, n_channels=2).signal
        v = diffuse_noise(n, PAIR, fs=FS, source=src)
    elif noise_kind == "wind":
        src = synthesize_noise("wind", n, fs=FS, rng=rng, n_channels=2).signal
        v = wind_noise(n, PAIR, fs=FS, wind_speed_mps=5.0, source=src)
    else:
        src = synthesize_noise("babble", n, fs=FS, rng=rng).signal[0]
        v = plane_wave(src, PAIR, azimuth_deg=float(noise_kind), fs=FS)
    v *= np.sqrt(np.mean(s[0] ** 2) / np.mean(v[0] ** 2) / 10 ** 0.5)
    return s, v


def replay_snr_i(e, s: np.ndarray, v: np.ndarray, start: int) -> float:
    """SNR-I (dB) of enhancer ``e`` on ``s + v`` (``(2, n)`` speech and noise images), scored from sample
    ``start`` on: the replayed speech over the replayed noise (after the latency) minus the front mic's."""
    r = e.process(s + v, FS)
    lat = e.tags.latency_samples
    snr_out = 10 * np.log10(_power(r.replay(s), start + lat) / _power(r.replay(v), start + lat))
    return snr_out - 10 * np.log10(_power(s[0], start) / _power(v[0], start))


def snr_improvements(names, *, seconds: float, settle_s: float, seed: int = 3, params=None) -> list[tuple]:
    """Rows ``(noise, mismatch label, SNR-I per enhancer...)`` for one seed (``params``: per-name overrides)."""
    rows = []
    for kind in ("135", "240", "diffuse", "wind"):
        s0, v0 = _scene(kind, seconds, seed)
        for mism in ((0.0, 0.0), (1.0, 5.0)):
            s, v = (rear_mismatch(c, gain_db=mism[0], phase_deg=mism[1]) for c in (s0, v0))
            row = [kind, f"{mism[0]:g} dB / {mism[1]:g} deg"]
            for name in names:
                row.append(replay_snr_i(enhancers.make(name, **(params or {}).get(name, {})), s, v, int(settle_s * FS)))
            rows.append(tuple(row))
    return rows


def white_noise_amplification(names, seconds: float = 6.0, seed: int = 5) -> list[tuple]:
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    look = plane_wave(rng.standard_normal(n), PAIR, azimuth_deg=0, fs=FS)
    white = 0.1 * rng.standard_normal((2, n))
    rows = []
    for name in names:
        r = enhancers.make(name).process(look + white, FS)
        ratio = (_power(r.replay(white), n // 2) / _power(white[0], n // 2)) / (
            _power(r.replay(look), n // 2) / _power(look[0], n // 2))
        rows.append((name, 10 * np.log10(ratio)))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--settle-s", type=float, default=8.0)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--seeds", type=int, default=3, help="speech/noise seeds averaged in the SNR-I table")
    ap.add_argument("--skip-rtf", action="store_true")
    args = ap.parse_args(argv)

    print("Null depth (dB), white-noise plane wave, ideal mics, second half of 4 s (target >= 30 dB)\n")
    print("| interferer | eb | eb-subband |\n| ---: | ---: | ---: |")
    for theta, a, b in null_depths():
        print(f"| {theta} deg | {a:.1f} | {b:.1f} |")

    names = ("eb", "eb-gated", "eb-subband", "eb-robust")
    print(f"\nSNR-I (dB, replay): speech 45 deg far field, babble, 5 dB SNR, {args.seconds:g} s, scored after "
          f"{args.settle_s:g} s; mean over {args.seeds} seeds\n")
    print("| noise | rear mic error | " + " | ".join(names) + " |")
    print("| --- | --- | " + " | ".join("---:" for _ in names) + " |")
    per_seed = [snr_improvements(names, seconds=args.seconds, settle_s=args.settle_s, seed=3 + 10 * k)
                for k in range(args.seeds)]
    values = np.array([[row[2:] for row in rows] for rows in per_seed])  # (seeds, rows, names)
    labels = [row[:2] for row in per_seed[0]]
    for (kind, mism), v in zip(labels, values.mean(axis=0)):
        print(f"| {kind} | {mism} | " + " | ".join(f"{x:.1f}" for x in v) + " |")
    print("\nloss from the mismatch (ideal - mismatched), dB: mean over seeds (worst seed)\n")
    print("| noise | " + " | ".join(names) + " |\n| --- | " + " | ".join("---:" for _ in names) + " |")
    loss = values[:, 0::2] - values[:, 1::2]  # (seeds, kinds, names)
    for i, (kind, _) in enumerate(labels[0::2]):
        print(f"| {kind} | " + " | ".join(f"{m:.1f} ({w:.1f})" for m, w in zip(loss[:, i].mean(axis=0),
                                                                              loss[:, i].max(axis=0))) + " |")

    print("\nBroadband white-noise amplification re the look direction (dB; target <= 6 for eb-robust)\n")
    print("| enhancer | amplification |\n| --- | ---: |")
    for name, db in white_noise_amplification(("cardioid", "eb", "eb-subband", "eb-robust")):
        print(f"| {name} | {db:.1f} |")

    if not args.skip_rtf:
        rows = measure([("eb-robust-ss", {}), ("eb-robust", {}), ("eb-ss", {})], seconds=10.0, runs=args.runs)
        print(f"\nBatch real-time factor, 10 s 2-ch 16 kHz, median of {args.runs} runs (target <= 0.01 for "
              f"eb-robust-ss); peer rfft+irfft {rows[0]['peer_s'] * 1e3:.2f} ms\n")
        print("| enhancer | batch RTF (wall) | batch RTF (cpu) | batch / peer |\n| --- | ---: | ---: | ---: |")
        for r in rows:
            print(f"| {r['enhancer']} | {r['batch']:.4f} | {r['batch_cpu']:.4f} | {r['batch'] * 10 / r['peer_s']:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
