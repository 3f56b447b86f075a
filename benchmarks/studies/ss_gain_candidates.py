"""Which ``ss`` gain keeps the talker's path still in Hagerman's pair (issue 16 part 3): the candidate table.

    python -m benchmarks.studies.ss_gain_candidates [--data-dir DIR] [--seeds N] [--snrs ...] [--noises ...]
        [--candidates NAME ...] [--no-pesq]

On the ``phone`` preset's conditions, ``eb-robust``'s front end is run once per condition and front end,
its speech and noise parts replayed (``F s``, ``F n``), and each candidate gain of ``eb-robust-ss``'s
``ss`` stage run on them (what the chain does: its replay composes the stages'):

* the front end fixed (:data:`FIXED_FRONT_END`: the same operation on ``s + n`` and ``s - n``, so the
  ``s - n`` run's input is ``F s - F n``), input SNR >= 15 dB: ss's own ``speech_jitter_db``
  (:func:`benchmarks.metrics.distortion.speech_jitter_db`, latency-aligned as
  :func:`benchmarks.studies.calibration_jitter.measure_condition` aligns it) -- worst and median per noise;
* ``eb-robust``'s defaults, every SNR: mean replay SNR-I and narrow-band PESQ (MOS-LQO of the aligned
  output, as :func:`benchmarks.metrics.evaluate.evaluate_enhancer` scores it), as changes from ``default``.

Candidates (:data:`CANDIDATES`): ``ss`` parameter sets (the averaged gain of :mod:`enhancers.single.ss`), and two
prototypes that were measured and rejected (:data:`PROTOTYPES`, not in ``ss``): the Berouti rule on
the tracker's smoothed power, and an Ephraim-Malah decision-directed a-priori SNR feeding it.  The
candidate numbers quoted in :mod:`enhancers.single.ss` were measured with a scratch copy of this computation
(1 December 2026, load average 2-10); this script reproduces its babble / 15 dB / seed 0 row for every
candidate to the printed digits, and the chosen set's per-noise numbers equal ``calibration_jitter --ss``'s.
Cost: the front end runs once per condition and front end; each candidate adds three ss runs and a PESQ
per condition (30-40 s per candidate for the 120 conditions at load average ~2, most of it PESQ).
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from benchmarks.metrics import speech as M
from benchmarks.metrics.distortion import speech_jitter_db
from benchmarks.run.sweep import load_sweep
from benchmarks.run.worker import render_group
from benchmarks.studies.calibration_jitter import _snr
from enhancers.core.registry import make, with_geometry
from enhancers.single.ss import subtraction_gain
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS

FIXED_FRONT_END = {"calibrate": False, "adapt_gate_db": -60.0, "mix_alpha0": 1.0}

CANDIDATES = {
    "default": {},
    "power-bins-2": {"power_bins": 2},
    "gain-smooth-0.5": {"gain_smooth": 0.5},
    "power-2-gain-smooth-0.5": {"power_bins": 2, "gain_smooth": 0.5},
    "averaged-2-2-0.55": {"power_bins": 2, "gain_bins": 2, "gain_smooth": 0.55},
    "averaged-3-3-0.4": {"power_bins": 3, "gain_bins": 3, "gain_smooth": 0.4},
}


def _tracker(x: np.ndarray, fs: int):
    """``ss``'s STFT power ``|X|^2``, smoothed power ``P`` and noise PSD ``Pn`` of ``x`` (``(F, K)`` each)."""
    e = make("ss")
    X = e.filterbank.analyze(x[None])[0]
    S = X.real ** 2 + X.imag ** 2
    P, Pn, _ = e._tracker_step(S, e._init_state(fs).tracker, fs)
    return S, P, Pn


def _berouti(mag, P, Pn):
    p = make("ss").params
    return subtraction_gain(mag, P, Pn, osub0=p.osub0, osub_slope=p.osub_slope, osub_min=p.osub_min,
                            osub_max=p.osub_max, subf=p.subf, gain_max=p.gain_max)


def tracker_power_gain(x: np.ndarray, fs: int) -> np.ndarray:
    """Prototype (a): the Berouti rule with ``|X|`` replaced by ``sqrt(P)`` (the tracker's 80 ms smoothing)."""
    _, P, Pn = _tracker(x, fs)
    return _berouti(np.sqrt(P), P, Pn)


def decision_directed_gain(x: np.ndarray, fs: int, a: float = 0.9) -> np.ndarray:
    """Prototype (c): ``xi = a G_{l-1}^2 |X_{l-1}|^2 / Pn + (1 - a) max(|X|^2 / Pn - 1, 0)`` (Ephraim-Malah),
    the Berouti rule on the power ``Pn (1 + xi)``."""
    S, P, Pn = _tracker(x, fs)
    G, prev = np.empty_like(S), np.zeros(S.shape[1])
    for f in range(S.shape[0]):
        pn = np.maximum(Pn[f], 1e-300)
        xi = a * prev / pn + (1.0 - a) * np.maximum(S[f] / pn - 1.0, 0.0)
        G[f] = _berouti(np.sqrt(pn * (1.0 + xi)), P[f], Pn[f])
        prev = G[f] ** 2 * S[f]
    return G


PROTOTYPES = {"tracker-power": tracker_power_gain, "decision-directed-0.9": decision_directed_gain}


def candidate_gain(name: str, x: np.ndarray, fs: int) -> np.ndarray:
    """The ``(F, K)`` gain mask candidate ``name`` applies to the one-channel signal ``x``."""
    if name in PROTOTYPES:
        return PROTOTYPES[name](x, fs)
    return make("ss", **CANDIDATES[name]).process(x[None], fs).trace["gain"]


def _apply(G: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``ss``'s replay of mask ``G`` on ``c`` (``(n,)``)."""
    fb = make("ss").filterbank
    return fb.synthesize(G[None] * fb.analyze(c[None]), c.size)[0]


def front_end_parts(cond, data_dir):
    """``{"fixed": (F s, F n, latency) or None below 15 dB, "default": ...}``, the reference and the
    input SNR's speech and noise at mic 0."""
    rendered = render_group(cond, data_dir)[0].mix(cond.snr_db)
    s, n = rendered.speech_image, rendered.noise_image
    parts = {}
    for fe, params in (("fixed", FIXED_FRONT_END), ("default", {})):
        if fe == "fixed" and cond.snr_db < 15:
            continue
        e = with_geometry(make("eb-robust", **params), spacing_m=cond.spacing_m, c_mps=SPEED_OF_SOUND_MPS)
        r = e.process(s + n, cond.fs)
        parts[fe] = (r.replay(s)[0], r.replay(n)[0], int(e.tags.latency_samples))
    return parts, rendered.reference[0], s[0], n[0]


def measure(cond, data_dir, names, pesq: bool = True) -> list[dict]:
    """One row per candidate: ``jitter`` (fixed front end, >= 15 dB only), ``snri`` and ``pesq`` (default front end)."""
    parts, ref, s0, n0 = front_end_parts(cond, data_dir)
    lat_ss = int(make("ss").tags.latency_samples)
    rows = []
    for name in names:
        row = dict(candidate=name, noise=cond.noise, snr=cond.snr_db, seed=cond.seed)
        if "fixed" in parts:
            Fs, Fn, lat = parts["fixed"]
            w1, w2 = (_apply(candidate_gain(name, x, cond.fs), Fs) for x in (Fs + Fn, Fs - Fn))
            row["jitter"] = speech_jitter_db(*(M.align(w, ref, latency_samples=lat + lat_ss)[0] for w in (w1, w2)))
        Fs, Fn, lat = parts["default"]
        G = candidate_gain(name, Fs + Fn, cond.fs)
        ys, yn = _apply(G, Fs), _apply(G, Fn)
        m = M.align(ys, ref, latency_samples=lat + lat_ss)[0].size
        row["snri"] = _snr(ys, yn, ref, lat + lat_ss) - M.snr_db(s0[:m], n0[:m])
        if pesq:
            y_al, ref_al = M.align(ys + yn, ref, latency_samples=lat + lat_ss)
            row["pesq"] = M.pesq_scores(ref_al, y_al, fs=cond.fs)["nb"]
        rows.append(row)
    return rows


def print_table(rows) -> None:
    base = {(r["noise"], r["snr"], r["seed"]): r for r in rows if r["candidate"] == "default"}
    groups = defaultdict(list)
    for r in rows:
        groups[(r["candidate"], r["noise"])].append(r)
    print("| candidate | noise | worst jitter | median jitter | SNR-I change | PESQ change |\n"
          "| --- | --- | ---: | ---: | ---: | ---: |")
    for (name, noise), g in groups.items():
        j = [r["jitter"] for r in g if "jitter" in r]
        b = [base[(r["noise"], r["snr"], r["seed"])] for r in g]
        dsnr = np.mean([r["snri"] - q["snri"] for r, q in zip(g, b)])
        dp = np.mean([r["pesq"] - q["pesq"] for r, q in zip(g, b)]) if "pesq" in g[0] else float("nan")
        print(f"| {name} | {noise} | {max(j):.1f} | {np.median(j):.1f} | {dsnr:+.2f} | {dp:+.3f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=None, help="real recordings (default: the built-in synthetic data)")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--snrs", type=float, nargs="*", default=None, help="input SNRs (default: all six)")
    ap.add_argument("--noises", nargs="*", default=None)
    ap.add_argument("--candidates", nargs="*", default=[*CANDIDATES, *PROTOTYPES],
                    choices=[*CANDIDATES, *PROTOTYPES], help="'default' is always added (the changes' reference)")
    ap.add_argument("--no-pesq", action="store_true")
    args = ap.parse_args(argv)
    names = ["default", *(c for c in args.candidates if c != "default")]
    rows = []
    for cond in load_sweep("phone").conditions():
        if cond.seed < args.seeds and (not args.snrs or cond.snr_db in args.snrs) and (
                not args.noises or cond.noise in args.noises):
            rows += measure(cond, args.data_dir, names, pesq=not args.no_pesq)
            print(".", end="", flush=True)
    print(f"\nphone, data: {args.data_dir or 'built-in'}, seeds 0..{args.seeds - 1}; jitter: front end fixed, "
          "input SNR >= 15 dB; changes from 'default' with eb-robust's defaults\n")
    print_table(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
