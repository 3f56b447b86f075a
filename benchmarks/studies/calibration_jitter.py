"""Issue 16 part 3 targets: does ``eb-robust``'s mic calibration listen to the talker?

    python -m benchmarks.studies.calibration_jitter [--data-dir DIR] [--seeds N] [--snrs 15 20 25]
        [--noises babble ...] [--blind | --direction]
        [--pooled | --combined | --frame | --frame-lowsnr | --frame-delayed | --frame-smooth | --frame-taper]
        [--set KEY=JSON ...]
        [--save-baseline FILE] [--baseline FILE]
        [--mismatch-seeds N] [--skip-mismatch] [--decompose] [--ss KEY=JSON ...] [--systems NAME ...] [--pesq]

``--ss KEY=JSON ...``: parameters of ``eb-robust-ss``'s ``ss`` stage (and of ``ss`` itself when it is one of
``--systems``), e.g. ``power_bins=3 gain_bins=3 gain_smooth=0.4`` (issue 16: ss's averaged gain).
``--systems``: the systems to run (default ``eb-robust eb-robust-ss``; the ss-floor table needs both); a
one-channel system gets the reference mic.  ``--pesq``: also each row's narrow-band PESQ (MOS-LQO, as
:func:`benchmarks.metrics.evaluate.evaluate_enhancer` scores the latency-aligned output), its mean per noise.

``--set KEY=JSON ...``: ``eb-robust`` parameters on top of the mode (e.g. ``beam_freeze='"level"'
level_frontal_db=1``; JSON lists become tuples), for both systems and the mismatch rows.

``--blind``: the calibration's talker-blind mode (:data:`TALKER_BLIND`: the level rule, its hold
and the start-up ramp; beta and the DAS weight then learn only where the calibration does) for
both systems; without it, their defaults.

``--direction``: the calibrated direction rule (:data:`DIRECTION`, the
forward/backward cardioid ratio of the calibrated pair per bin, no level rule) instead.

``--pooled``: beta and the DAS weight pooled over bands (:data:`POOLED`, :mod:`enhancers.beam.beam_pool`).
``--combined``: every talker-blind piece together (:data:`COMBINED`, :data:`COMBINED_SS`; measured there).
``--frame``: :data:`COMBINED` with the frame rule and the delayed DAS weight (:data:`FRAME`);
``--frame-lowsnr``: the same learning during speech at low input SNR (:data:`FRAME_LOWSNR`);
``--frame-delayed``: that with beta learned late too (:data:`FRAME_DELAYED`);
``--frame-smooth``: that with every decision that differed between the two runs made continuous or left
out (:data:`FRAME_SMOOTH`); ``--frame-taper``: that with the edges that still flipped graded and SNR-I bought
back at the stream start (:data:`FRAME_TAPER`); ``--frame-settled``: that with the frame rule's decisions trusted
only once a noise field that starts with the stream has built up (:data:`FRAME_SETTLED`).

On the ``phone`` preset's conditions (its first ``--seeds`` seeds, every noise and SNR, or the
``--snrs`` given; ``--first-seed K``: seeds ``K .. K + N - 1`` instead -- phones and utterances the settings
were not tuned on, e.g. ``--first-seed 5``), for ``eb-robust`` and ``eb-robust-ss``, each run twice -- on ``s + n``
(operation ``W1``) and on ``s - n`` (``W2``), Hagerman & Olofsson's pair -- it prints:

1. ``speech_jitter_db`` (:func:`benchmarks.metrics.distortion.speech_jitter_db` of ``W1 s`` and ``W2 s``,
   latency-aligned) per noise and input SNR: max over seeds (target <= -30 dB for
   ``eb-robust-ss`` where the input SNR is >= 15 dB) and mean;
2. the fraction of rows whose replay SNR-I (``W1 s`` over ``W1 n``) and Hagerman SNR-I
   (``(y1 + y2) / 2`` over ``(y1 - y2) / 2``) are within 3 dB (target >= 95 %), measured as
   :func:`benchmarks.metrics.evaluate.evaluate_enhancer` measures them (same alignment, same input SNR);
3. mean replay SNR-I per noise, and with ``--baseline FILE`` (written by ``--save-baseline`` on
   another version of the code) the change (target: no more than 1 dB below);
4. issue 12's mismatch loss (:func:`benchmarks.studies.robust_eb.snr_improvements`: 20 s, scored
   after 8 s, speech 45 deg, babble at 135 / 240 deg or diffuse, wind; ideal minus 1 dB / 5 deg
   rear mic) for ``eb-robust`` (target <= 2 dB at 135, 240 deg and diffuse).

5. ``ss``'s own jitter (:func:`ss_floor`): ``eb-robust-ss``'s in the conditions where ``eb-robust``'s front
   end is the same operation in both runs -- the part no calibration can remove (every row, with a fixed
   front end: ``--set calibrate=false adapt_gate_db=-60 mix_alpha0=1.0``, the DAS path frozen at its prior);
6. with ``--decompose``: for every ``eb-robust`` row above -30 dB, the jitter when only one adapted
   quantity differs between the runs (``r_hat``, ``beta`` with the EQ it sets, ``alpha``):
   :func:`swap_jitter`.

Cost: every condition is rendered once and each system run twice (plus replays); the full
``phone`` (5 seeds, 90 conditions) takes a few minutes on one core.

Measured with ``--ss power_bins=2 gain_bins=2 gain_smooth=0.55`` (ss's averaged gain,
:mod:`enhancers.single.ss`; 1 December 2026, load average 8-10 on 2 cores, 5 seeds, built-in data / ``--data-dir
/work/shared/data``):

* ss's own jitter (``--set calibrate=false adapt_gate_db=-60 mix_alpha0=1.0 --snrs 15 20 25``), worst /
  median over the 15 rows per noise, default ss -> averaged gain: babble -25.5 / -32.2 -> -33.2 / -40.0
  (shared data -27.1 / -32.8 -> -34.2 / -40.3), factory -31.3 / -38.3 -> -38.6 / -45.7 (-31.3 -> -39.6),
  factory-hall -28.9 / -34.7 -> -37.7 / -42.6 (-28.2 -> -36.0), wind -31.6 / -36.8 -> -39.5 / -44.9
  (-31.5 -> -38.8): every row <= -33 dB.
* ``eb-robust-ss`` with its default front end (``--systems ss eb-robust-ss --pesq``, all six SNRs,
  ``--baseline`` from the same run without ``--ss``): mean replay SNR-I change babble -0.40 / -0.11 dB,
  factory -0.18 / +0.08, factory-hall +0.11 / +0.38, wind -0.55 / -0.40; mean PESQ (nb MOS-LQO)
  +0.093 / +0.037, +0.064 / +0.035, +0.058 / +0.059, +0.048 / +0.001.
* ``ss`` alone (reference mic): worst jitter at 15 dB babble -22.6 -> -31.5 (shared -22.8 -> -30.7), wind
  -22.1 -> -31.0 (-20.8 -> -23.6); SNR-I change -0.30 / -0.26 (babble), -0.64 / -0.55 (wind), +0.68 / +0.88
  (factory); PESQ +0.06 to +0.13.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np

from benchmarks.metrics import speech as M
from benchmarks.metrics.distortion import speech_jitter_db
from benchmarks.run.sweep import load_sweep
from benchmarks.run.worker import render_group
from benchmarks.studies.robust_eb import snr_improvements
from enhancers.core.registry import make, with_geometry
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS

SYSTEMS = ("eb-robust", "eb-robust-ss")
AGREE_DB = 3.0
# the best opt-in setting measured (docs/history/2026-12-calibration-talker-blind.md); an earlier
# one was {"freeze_level_db": 3.0, "ramp_frames": 40.0} (beam_freeze "both", no frontal condition)
TALKER_BLIND = {"freeze_level_db": 3.0, "ramp_frames": 40.0, "ramp_over_band": True, "level_frontal_db": -1.0,
                "beam_freeze": "level"}

# the calibrated direction rule (enhancers/beam/mic_calibration.py); the best of its
# thresholds measured (-2 dB: the lowest jitter; it freezes almost every cell of diffuse or incoherent noise)
DIRECTION = {"cal_frontal_db": -2.0, "level_scope": "bin", "cal_frontal_beam": True, "ramp_frames": 40.0,
             "ramp_over_band": True, "beam_freeze": "level"}

# pooled beta and DAS weight (issue 16 part 3, enhancers/beam/beam_pool.py): one rear direction for the whole band
# (normaliser over the learned cells only, step 0.015 per frame) and the DAS weight in three bands (0-1, 1-4, 4-8 kHz)
# held near its prior until a band has learned 300 cells
POOLED = {"beta_model": "direction", "mu": 0.015, "beta_norm": "learned", "mix_bands_hz": (1000.0, 4000.0),
          "mix_ramp_cells": 300.0}


# every talker-blind piece of issue 16 part 3 together (session 23's best measured combination; all opt-in):
# the calibration learns only where the level rule (per bin, 0.3 s hold, 0.15 s look ahead) says the talker is
# absent, with the parametric sensor model (model="hp1") and the start-up ramp; beta on its own gate as one
# rear direction (POOLED without the DAS ramp); the DAS weight in three bands from the DAS prior 1; the EQ's
# bound from a fixed pattern (eq_bound_beta=0); ss's gain averaged over bins and frames (COMBINED_SS).
# Measured (5 seeds, every noise and SNR; load ~2-3 on 2 cores), eb-robust-ss against today's default:
#   jitter at >= 15 dB, worst / median / rows above -30: built-in -25.1 / -40.0 / 8 of 60 (default -7.7, 60 of
#   60); ../shared/data -12.4 / -35.0 / 16 of 60 (default -1.2); replay = Hagerman within 3 dB on 100 % / 98 %;
#   mean SNR-I change per noise (built-in / shared) babble -0.79 / -0.25, factory -3.96 / -3.33, factory-hall
#   +1.80 / +1.15, wind +0.14 / -0.17 dB; issue 12's mismatch loss 28.5 / 30.3 / 1.4 dB at 135 / 240 deg /
#   diffuse (the level rule never lets the calibration learn behind that talker) -- so it misses the
#   factory SNR-I and mismatch targets and the jitter target in the hall and wind rows.
COMBINED = {**POOLED, "mix_ramp_cells": 0.0, "model": "hp1", "eq_bound_beta": 0.0, "mix_alpha0": 1.0,
            "ramp_frames": 40.0, "ramp_over_band": True, "freeze_level_db": 3.0, "level_scope": "bin",
            "level_hang_s": 0.3, "level_ahead_s": 0.15, "beam_freeze": "cardioid"}
COMBINED_SS = {"power_bins": 2, "gain_bins": 2, "gain_smooth": 0.55}

# the frame rule (enhancers/beam/mic_calibration.py): COMBINED with the level rule and the
# cardioid rules replaced by ONE level-free decision per frame -- the forward/backward cardioid ratio over
# 1-4 kHz above 5 dB, held 0.2 s after and 0.24 s before -- and the DAS weight learned on it, 0.24 s late
# (mix_model="delayed"); measured in the module docstring of enhancers/beam/mic_calibration.py
FRAME = {**COMBINED, "freeze_level_db": None, "frame_q_db": 5.0, "level_hang_s": 0.2, "level_ahead_s": 0.24,
         "beam_freeze": "das", "mix_model": "delayed"}
# the same, giving SNR-I back: below ~6 dB estimated input SNR the calibration and the DAS weight learn on the
# cardioid rules' cells again (frame_snr_db: the noise masks the talker there); the DAS weight learned at once on
# the frames before the talker is first heard stands in for the delayed one until that has 2000 cells of a band;
# beta per bin (the deeper null of one plane wave), frozen where the frame rule hears the talker at high SNR
FRAME_LOWSNR = {**FRAME, "frame_snr_db": (6.0, 12.0), "mix_fast_cells": 2000.0, "beta_model": "bin", "mu": 0.1,
                "beta_norm": "frame", "beam_freeze": "level"}
# the same with beta learned late as well : one least-squares beta per bin on the
# calibration's held weights, 0.24 s late (beta_model="delayed"; beta_fast_frames: a start-up stand-in for its
# first 10 frames); the frame rule also judges 250 Hz-1 kHz on its own (frame_low_hz: a voiced syllable's power
# lies there) and stops at a frame 20 dB over the noise floor (frame_level_db); the DAS weight's stand-in only
# until 500 cells and shrunk towards its prior for its first 200 (mix_ramp_cells); the calibration learns
# rear-dominated cells in a talker's frames too (cal_rear_db=10: issue 12's 135 deg mismatch)
FRAME_DELAYED = {**FRAME_LOWSNR, "beta_model": "delayed", "beam_freeze": "das", "beta_fast_frames": 10.0,
                 "mix_fast_cells": 500.0, "mix_ramp_cells": 200.0, "cal_rear_db": 10.0, "frame_low_hz": 250.0,
                 "frame_level_db": 20.0}
# the same with the decisions that differed between the runs on s + n and s - n made continuous or left out
# : the rear rule's threshold follows the SNR share (cal_rear_db at high input SNR,
# cal_rear_low_db=6 at low: issue 12's 240 deg mismatch), the frame rule's decisions in the first 0.05 s are
# not trusted (frame_start_s: a recording's start transient), the stand-ins hand over to the delayed estimates
# linearly (fast_blend), the SNR share grows with the frames it has seen (frame_snr_frames=40) and takes the
# noise's power from the frames away from the ratio rule's talker frames (frame_snr_quiet, frame_snr_quiet_ratio:
# a reverberant talker's unmarked frames are not noise, a machine's hits are), over 250 Hz-4 kHz
# (frame_snr_low_hz: the talker's band) and a range 2 dB higher (frame_snr_db=(8, 14); issue 12's 135 deg)
FRAME_SMOOTH = {**FRAME_DELAYED, "cal_rear_low_db": 6.0, "frame_start_s": 0.05, "fast_blend": True,
                "frame_snr_frames": 40.0, "frame_snr_quiet": True, "frame_snr_quiet_ratio": True,
                "frame_snr_low_hz": 250.0, "frame_snr_db": (8.0, 14.0)}
# the same with the edges that still flipped between the runs graded : the frame rule's
# hold tapers over 0.05 s at both ends (frame_hold_taper_s: an onset heard a frame apart moved a whole noise
# frame), the rear rule's weight ramps over 3 dB above cal_rear_db on a slower smoother (cal_rear_soft_db,
# cal_rear_lam: the talker x noise cross term in P_F decided cells near the threshold), the SNR share's noise
# average skips a frame 15 dB over it (frame_snr_clip_db: a talker the ratio missed made 15 dB input read ~5 dB);
# and SNR-I bought back where it was lost, at the stream start (factory at 0-5 dB: the null learned late): the
# DAS weight's stand-in unshrunk (mix_fast_ramp_cells=0) and from the prior 0 (mix_alpha0), the share's ramp
# over 10 frames
FRAME_TAPER = {**FRAME_SMOOTH, "frame_hold_taper_s": 0.05, "cal_rear_soft_db": 3.0, "cal_rear_lam": 0.8,
               "frame_snr_clip_db": 15.0, "mix_fast_ramp_cells": 0.0, "mix_alpha0": 0.0, "frame_snr_frames": 10.0}
# the same with the frame rule's first 0.13 s untrusted : a noise field that starts with
# the stream -- the hall's machines, rendered from t = 0 -- builds up over its first ~50 ms and its first arrivals
# read as a frontal talker to 0.125 s; judged, that ended the DAS weight's start-up stand-in after 6 frames,
# whose cross term with the speech recording's own background then differed between the runs for the whole file
FRAME_SETTLED = {**FRAME_TAPER, "frame_start_s": 0.13}


def _params(blind, overrides=None) -> dict:
    """``eb-robust``'s parameters: :data:`TALKER_BLIND` (``blind``) or none, then ``overrides``."""
    return {**(TALKER_BLIND if blind else {}), **(overrides or {})}


def _make(name: str, blind, overrides=None, ss=None):
    """``eb-robust`` (or the chain with it as stage ``eb``), talker-blind or with its defaults, plus ``overrides``;
    ``ss``: parameters of the chain's ``ss`` stage (or of ``ss`` itself).  Any other name: its defaults."""
    params = _params(blind, overrides)
    if name == "ss":
        return make(name, **(ss or {}))
    if name == "eb-robust":
        return make(name, **params)
    if name == "eb-robust-ss":
        stages = {**({"eb": params} if params else {}), **({"ss": ss} if ss else {})}
        return make(name, **stages)
    return make(name)


def _snr(s_out, n_out, ref, latency) -> float:
    s_al, _ = M.align(s_out, ref, latency_samples=latency)
    n_al, _ = M.align(n_out, ref, latency_samples=latency)
    return M.snr_db(s_al, n_al)


def render_parts(cond, data_dir):
    """``(speech image (2, n), noise image (2, n), reference (n,))`` of a ``phone`` condition at its SNR."""
    rendered = render_group(cond, data_dir)[0].mix(cond.snr_db)
    return rendered.speech_image, rendered.noise_image, rendered.reference[0]


def measure_condition(cond, data_dir, names=SYSTEMS, *, blind: bool = False, overrides=None, ss=None,
                      pesq: bool = False, parts=None) -> list[dict]:
    """One row per system: jitter, replay and Hagerman SNR-I (and with ``pesq`` the output's PESQ) of the
    condition (see module docstring); ``parts``: :func:`render_parts`' output when the caller has it."""
    speech, noise, ref = parts if parts is not None else render_parts(cond, data_dir)
    rows = []
    for name in names:
        e = with_geometry(_make(name, blind, overrides, ss), spacing_m=cond.spacing_m, c_mps=SPEED_OF_SOUND_MPS)
        s, n = (x[:e.tags.channels_in] for x in (speech, noise))
        lat = int(e.tags.latency_samples)
        r1, r2 = e.process(s + n, cond.fs), e.process(s - n, cond.fs)
        w1s, w2s, w1n = r1.replay(s)[0], r2.replay(s)[0], r1.replay(n)[0]
        a1, _ = M.align(w1s, ref, latency_samples=lat)
        a2, _ = M.align(w2s, ref, latency_samples=lat)
        m = a1.size
        snr_in = M.snr_db(s[0][:m], n[0][:m])
        y1, y2 = r1.output[0], r2.output[0]
        rows.append(dict(system=name, noise=cond.noise, snr=cond.snr_db, seed=cond.seed,
                         jitter=speech_jitter_db(a1, a2),
                         replay=_snr(w1s, w1n, ref, lat) - snr_in,
                         hagerman=_snr(0.5 * (y1 + y2), 0.5 * (y1 - y2), ref, lat) - snr_in))
        if pesq:
            y_al, ref_al = M.align(y1, ref, latency_samples=lat)
            rows[-1]["pesq"] = M.pesq_scores(ref_al, y_al, fs=cond.fs)["nb"]
    return rows


def swap_jitter(cond, data_dir, params: dict) -> dict[str, float]:
    """``eb-robust``'s jitter on one condition with everything from the ``s + n`` run but one adapted
    quantity from the ``s - n`` run: ``{"all": ..., "r_hat": ..., "beta": ... (with its EQ), "alpha": ...}``
    (dB; which quantity carries the talker).  Reads the per-frame record the enhancer replays."""
    s, n, ref = render_parts(cond, data_dir)
    e = with_geometry(make("eb-robust", **params), spacing_m=cond.spacing_m, c_mps=SPEED_OF_SOUND_MPS)
    lat, fb, S = int(e.tags.latency_samples), e.filterbank, e.filterbank.analyze(s)
    rec1, rec2 = (e._step(x, e._init_state(cond.fs))[2] for x in (s + n, s - n))

    def talker(rec):
        y = fb.synthesize(e._apply(rec, S, cond.fs), s.shape[-1])[0]
        return M.align(y, ref, latency_samples=lat)[0]

    y1 = talker(rec1)
    out = {"all": speech_jitter_db(y1, talker(rec2))}
    for keys in (("r_hat",), ("beta", "eq"), ("alpha",)):
        if keys[0] in rec1:
            out[keys[0]] = speech_jitter_db(y1, talker({**rec1, **{k: rec2[k] for k in keys}}))
    return out


def phone_rows(data_dir, *, seeds: int, snrs=None, noises=None, blind: bool = False, overrides=None,
               progress=False, names=SYSTEMS, ss=None, pesq: bool = False, first_seed: int = 0) -> list[dict]:
    """The rows of ``phone``'s conditions with seeds ``first_seed .. first_seed + seeds - 1`` (the preset's seed
    list extended as ``bench run --seeds`` does), ``snrs`` and ``noises`` (None: all)."""
    rows = []
    for cond in load_sweep("phone").with_seeds(first_seed + seeds).conditions():
        if cond.seed < first_seed or (snrs and cond.snr_db not in snrs) or (noises and cond.noise not in noises):
            continue
        rows += measure_condition(cond, data_dir, names, blind=blind, overrides=overrides, ss=ss, pesq=pesq)
        if progress:
            print(".", end="", flush=True)
    if progress:
        print()
    return rows


def _group(rows, *keys):
    out = defaultdict(list)
    for r in rows:
        out[tuple(r[k] for k in keys)].append(r)
    return out


def per_noise_means(rows, key: str = "replay") -> dict[str, float]:
    """``{"system/noise": mean replay SNR-I}`` (or the mean of another column ``key``)."""
    return {f"{s}/{nz}": float(np.mean([r[key] for r in g])) for (s, nz), g in sorted(_group(rows, "system", "noise").items())}


def ss_floor(rows) -> dict[str, list[float]]:
    """Per noise, ``eb-robust-ss``'s jitter (input SNR >= 15 dB) in the conditions where ``eb-robust``'s is
    below -100 dB: there the front end is the same operation in both runs, so what remains is ``ss``'s own
    (its gain follows the mixture, ``|s + n|`` in one run and ``|s - n|`` in the other)."""
    fixed = {(r["noise"], r["snr"], r["seed"]) for r in rows if r["system"] == "eb-robust" and r["jitter"] < -100}
    out = defaultdict(list)
    for r in rows:
        if r["system"] == "eb-robust-ss" and r["snr"] >= 15 and (r["noise"], r["snr"], r["seed"]) in fixed:
            out[r["noise"]].append(r["jitter"])
    return dict(out)


def print_ss_floor(rows) -> None:
    floor = ss_floor(rows)
    if floor:
        print("\nss's own jitter: eb-robust-ss where eb-robust's front end is identical in both runs (jitter < -100 dB)\n")
        print("| noise | rows | worst | median | above -30 dB |\n| --- | ---: | ---: | ---: | ---: |")
        for noise, j in sorted(floor.items()):
            print(f"| {noise} | {len(j)} | {max(j):.1f} | {np.median(j):.1f} | {sum(x > -30 for x in j)} |")


def print_tables(rows, baseline: dict | None) -> None:
    print("\nspeech_jitter_db (max / mean over seeds); target <= -30 dB for eb-robust-ss at input SNR >= 15 dB\n")
    print("| system | noise | " + " | ".join(f"{snr:g} dB" for snr in sorted({r['snr'] for r in rows})) + " |")
    print("| --- | --- |" + " ---: |" * len({r["snr"] for r in rows}))
    for (sysname, noise), g in sorted(_group(rows, "system", "noise").items()):
        cells = []
        for _snr, gs in sorted(_group(g, "snr").items()):
            j = [r["jitter"] for r in gs]
            cells.append(f"{max(j):.1f} / {np.mean(j):.1f}")
        print(f"| {sysname} | {noise} | " + " | ".join(cells) + " |")
    hi = [r["jitter"] for r in rows if r["system"] == "eb-robust-ss" and r["snr"] >= 15]
    if hi:
        print(f"\neb-robust-ss worst jitter at >= 15 dB: {max(hi):.1f} dB, median {np.median(hi):.1f} dB "
              f"({sum(j > -30 for j in hi)} of {len(hi)} rows above -30 dB)")
    print_ss_floor(rows)
    print(f"\nreplay vs Hagerman SNR-I within {AGREE_DB:g} dB (target >= 95 % for eb-robust-ss)\n")
    print("| system | rows within | max abs diff (dB) |\n| --- | ---: | ---: |")
    for (sysname,), g in sorted(_group(rows, "system").items()):
        d = np.abs([r["replay"] - r["hagerman"] for r in g])
        print(f"| {sysname} | {np.mean(d <= AGREE_DB):.0%} ({int(np.sum(d <= AGREE_DB))}/{d.size}) | {d.max():.1f} |")
    print("\nmean replay SNR-I per noise (dB)" + (" vs baseline (target: change >= -1 dB)" if baseline else "") + "\n")
    print("| system/noise | SNR-I | baseline | change |\n| --- | ---: | ---: | ---: |")
    for key, v in per_noise_means(rows).items():
        b = (baseline or {}).get(key)
        print(f"| {key} | {v:.2f} | " + ("" if b is None else f"{b:.2f} | {v - b:+.2f}") + " |")
    if rows and "pesq" in rows[0]:
        print("\nmean PESQ (narrow-band MOS-LQO) per noise\n\n| system/noise | PESQ | baseline | change |\n"
              "| --- | ---: | ---: | ---: |")
        for key, v in per_noise_means(rows, "pesq").items():
            b = (baseline or {}).get("pesq:" + key)
            print(f"| {key} | {v:.3f} | " + ("" if b is None else f"{b:.3f} | {v - b:+.3f}") + " |")


def print_decomposition(rows, data_dir, params: dict) -> None:
    print("\neb-robust jitter (dB) with one adapted quantity swapped between the s + n and s - n runs, "
          "rows above -30 dB\n")
    print("| noise | SNR | seed | all | r_hat | beta+EQ | alpha |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    conds = {(c.noise, c.snr_db, c.seed): c for c in load_sweep("phone").conditions()}
    for r in rows:
        if r["system"] == "eb-robust" and r["jitter"] > -30:
            d = swap_jitter(conds[(r["noise"], r["snr"], r["seed"])], data_dir, params)
            print(f"| {r['noise']} | {r['snr']:g} | {r['seed']} | " + " | ".join(
                f"{d[k]:.1f}" if k in d else "" for k in ("all", "r_hat", "beta", "alpha")) + " |")


def print_mismatch(seeds: int, blind: bool = False, overrides=None) -> None:
    print("\neb-robust mismatch loss (dB): ideal minus 1 dB / 5 deg rear mic, 20 s scored after 8 s, "
          f"mean of {seeds} seed(s); target <= 2 dB at 135, 240 deg and diffuse\n")
    print("| noise | ideal SNR-I | mismatched SNR-I | loss |\n| --- | ---: | ---: | ---: |")
    params = {"eb-robust": _params(blind, overrides)} if blind or overrides else None
    per_seed = [snr_improvements(("eb-robust",), seconds=20.0, settle_s=8.0, seed=3 + 10 * k, params=params)
                for k in range(seeds)]
    for i in range(0, len(per_seed[0]), 2):
        ideal = np.mean([rows[i][2] for rows in per_seed])
        mism = np.mean([rows[i + 1][2] for rows in per_seed])
        print(f"| {per_seed[0][i][0]} | {ideal:.1f} | {mism:.1f} | {ideal - mism:.2f} |")  # (2 decimals: a 2 dB target)


def _key_json(items, option: str) -> dict:
    """``{key: value}`` from ``KEY=JSON`` strings; ``ValueError`` naming the option and the item otherwise."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        try:
            if not (key and sep):
                raise ValueError("no '='")
            out[key] = json.loads(value)
        except ValueError as e:
            raise ValueError(f"{option} {item!r}: expected KEY=JSON, e.g. beam_freeze='\"level\"' or mu=0.02 ({e})") from None
    return out


def parse_set(items, option: str = "--set") -> dict:
    """``eb-robust`` parameters from ``KEY=JSON`` strings (JSON lists become tuples: the bands are pairs).

    >>> parse_set(["mu=0.02", 'beam_freeze="level"', "mix_bands_hz=[1000, 4000]"])
    {'mu': 0.02, 'beam_freeze': 'level', 'mix_bands_hz': (1000, 4000)}
    """
    return {k: tuple(v) if isinstance(v, list) else v for k, v in _key_json(items, option).items()}


def mode_params(args) -> tuple[dict, dict]:
    """``(eb-robust overrides, ss-stage parameters)`` from the parsed options: the named setting
    (``--direction``, ``--pooled``, ``--combined``) under the explicit ``--set`` / ``--ss`` values."""
    overrides, ss = parse_set(args.set), _key_json(args.ss, "--ss")
    frame = (FRAME_SETTLED if args.frame_settled else FRAME_TAPER if args.frame_taper else FRAME_SMOOTH
             if args.frame_smooth else FRAME_DELAYED if args.frame_delayed else FRAME_LOWSNR if args.frame_lowsnr
             else FRAME if args.frame else {})
    named = {**(DIRECTION if args.direction else {}), **(POOLED if args.pooled else {}),
             **(COMBINED if args.combined else {}), **frame}
    return {**named, **overrides}, {**(COMBINED_SS if args.combined or frame else {}), **ss}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=None, help="real recordings (default: the built-in synthetic data)")
    ap.add_argument("--seeds", type=int, default=5, help="the phone preset's first N seeds (default 5)")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="start at this seed instead of 0 (e.g. 5: seeds the settings were not tuned on)")
    ap.add_argument("--snrs", type=float, nargs="*", default=None, help="input SNRs to keep (default: all six)")
    ap.add_argument("--noises", nargs="*", default=None, help="noises to keep (default: all of phone's)")
    ap.add_argument("--blind", action="store_true", help="the calibration's talker-blind mode (TALKER_BLIND)")
    ap.add_argument("--direction", action="store_true", help="the calibrated direction rule (DIRECTION)")
    ap.add_argument("--pooled", action="store_true", help="pooled beta and DAS weight (POOLED), beside either mode")
    ap.add_argument("--combined", action="store_true",
                    help="every talker-blind piece together (COMBINED, and COMBINED_SS for the ss stage)")
    ap.add_argument("--frame", action="store_true", help="COMBINED with the frame rule and the delayed DAS weight (FRAME)")
    ap.add_argument("--frame-lowsnr", action="store_true",
                    help="FRAME learning during speech at low input SNR, with a fast start and beta per bin (FRAME_LOWSNR)")
    ap.add_argument("--frame-delayed", action="store_true",
                    help="FRAME_LOWSNR with beta learned late too, the low band and level rules (FRAME_DELAYED)")
    ap.add_argument("--frame-smooth", action="store_true",
                    help="FRAME_DELAYED with the decisions that differed between the runs made continuous (FRAME_SMOOTH)")
    ap.add_argument("--frame-taper", action="store_true",
                    help="FRAME_SMOOTH with the hold's and the rear rule's edges graded (FRAME_TAPER)")
    ap.add_argument("--frame-settled", action="store_true",
                    help="FRAME_TAPER with the frame rule's first 0.13 s untrusted (FRAME_SETTLED)")
    ap.add_argument("--decompose", action="store_true", help="per adapted quantity, eb-robust's rows above -30 dB")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=JSON",
                    help="eb-robust parameters on top of the mode, e.g. beam_freeze=\"level\"")
    ap.add_argument("--ss", nargs="*", default=[], metavar="KEY=JSON",
                    help="parameters of eb-robust-ss's ss stage (and of ss), e.g. gain_smooth=0.4")
    ap.add_argument("--systems", nargs="*", default=list(SYSTEMS), help="systems to run (default: eb-robust eb-robust-ss)")
    ap.add_argument("--pesq", action="store_true", help="also the output's PESQ per row (mean per noise)")
    ap.add_argument("--save-baseline", default=None, help="write the per-noise mean SNR-I (and PESQ) to this JSON file")
    ap.add_argument("--baseline", default=None, help="compare the per-noise mean SNR-I with this JSON file")
    ap.add_argument("--mismatch-seeds", type=int, default=1)
    ap.add_argument("--skip-mismatch", action="store_true")
    args = ap.parse_args(argv)
    try:
        overrides, ss = mode_params(args)
    except ValueError as e:
        ap.error(str(e))  # one line and the usage, exit status 2
    rows = phone_rows(args.data_dir, seeds=args.seeds, snrs=args.snrs, noises=args.noises, blind=args.blind,
                      overrides=overrides, progress=True, names=tuple(args.systems), ss=ss, pesq=args.pesq,
                      first_seed=args.first_seed)
    baseline = None
    if args.baseline:
        with open(args.baseline) as f:
            baseline = json.load(f)
    mode = ("talker-blind " if args.blind else "defaults ") + json.dumps(_params(args.blind, overrides))
    print(f"phone, data: {args.data_dir or 'built-in'}, seeds {args.first_seed}..{args.first_seed + args.seeds - 1}, "
          f"{len(rows) // len(args.systems)} "
          f"conditions, calibration: {mode}, ss stage: {json.dumps(ss)}")
    print_tables(rows, baseline)
    if args.save_baseline:
        pesq = {"pesq:" + k: v for k, v in per_noise_means(rows, "pesq").items()} if args.pesq else {}
        with open(args.save_baseline, "w") as f:
            json.dump({**per_noise_means(rows), **pesq}, f, indent=1)
    if args.decompose:
        print_decomposition(rows, args.data_dir, _params(args.blind, overrides))
    if not args.skip_mismatch:
        print_mismatch(args.mismatch_seeds, args.blind, overrides)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
