"""Issue 16 part 3 targets: does ``eb-robust``'s mic calibration listen to the talker?

    python -m benchmarks.studies.calibration_jitter [--data-dir DIR] [--seeds N] [--snrs 15 20 25]
        [--noises babble ...] [--blind] [--set KEY=JSON ...]
        [--save-baseline FILE] [--baseline FILE]
        [--mismatch-seeds N] [--skip-mismatch] [--decompose] [--ss KEY=JSON ...] [--systems NAME ...] [--pesq]

``--ss KEY=JSON ...``: parameters of ``eb-robust-ss``'s ``ss`` stage (and of ``ss`` itself when it is one of
``--systems``), e.g. ``power_bins=3 gain_bins=3 gain_smooth=0.4`` (issue 16: ss's averaged gain).
``--systems``: the systems to run (default ``eb-robust eb-robust-ss``; the ss-floor table needs both); a
one-channel system gets the reference mic.  ``--pesq``: also each row's narrow-band PESQ (MOS-LQO, as
:func:`benchmarks.metrics.evaluate.evaluate_enhancer` scores the latency-aligned output), its mean per noise.

``--set KEY=JSON ...``: ``eb-robust`` parameters on top of the mode (e.g. ``frame_q_db=4
mix_bands_hz='[1000, 4000]'``; JSON lists become tuples), for both systems and the mismatch rows.

``--blind``: ``eb-robust-blind``'s settings (:data:`enhancers.beam.presets.EB_ROBUST_BLIND`, and
:data:`~enhancers.beam.presets.EB_ROBUST_BLIND_SS` for the ``ss`` stage: the talker-blind rules of
:mod:`enhancers.beam.mic_calibration`) for both systems; without it, their defaults.

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
from enhancers.beam.presets import EB_ROBUST_BLIND, EB_ROBUST_BLIND_SS
from enhancers.core.registry import make, with_geometry
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS

SYSTEMS = ("eb-robust", "eb-robust-ss")
AGREE_DB = 3.0
#: ``--blind``: eb-robust-blind's eb-robust parameters and its ss stage's
TALKER_BLIND, TALKER_BLIND_SS = EB_ROBUST_BLIND, EB_ROBUST_BLIND_SS


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
            raise ValueError(f"{option} {item!r}: expected KEY=JSON, e.g. model='\"hp1\"' or mu=0.02 ({e})") from None
    return out


def parse_set(items, option: str = "--set") -> dict:
    """``eb-robust`` parameters from ``KEY=JSON`` strings (JSON lists become tuples: the bands are pairs).

    >>> parse_set(["mu=0.02", 'model="hp1"', "mix_bands_hz=[1000, 4000]"])
    {'mu': 0.02, 'model': 'hp1', 'mix_bands_hz': (1000, 4000)}
    """
    return {k: tuple(v) if isinstance(v, list) else v for k, v in _key_json(items, option).items()}


def mode_params(args) -> tuple[dict, dict]:
    """``(eb-robust overrides, ss-stage parameters)`` from the parsed options: the explicit ``--set`` / ``--ss``
    values, the ss stage's over :data:`TALKER_BLIND_SS` with ``--blind`` (``--blind``'s eb-robust parameters are
    :func:`_params`')."""
    overrides, ss = parse_set(args.set), _key_json(args.ss, "--ss")
    return overrides, {**(TALKER_BLIND_SS if args.blind else {}), **ss}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=None, help="real recordings (default: the built-in synthetic data)")
    ap.add_argument("--seeds", type=int, default=5, help="the phone preset's first N seeds (default 5)")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="start at this seed instead of 0 (e.g. 5: seeds the settings were not tuned on)")
    ap.add_argument("--snrs", type=float, nargs="*", default=None, help="input SNRs to keep (default: all six)")
    ap.add_argument("--noises", nargs="*", default=None, help="noises to keep (default: all of phone's)")
    ap.add_argument("--blind", action="store_true",
                    help="eb-robust-blind's settings (TALKER_BLIND, and TALKER_BLIND_SS for the ss stage)")
    ap.add_argument("--decompose", action="store_true", help="per adapted quantity, eb-robust's rows above -30 dB")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=JSON",
                    help="eb-robust parameters on top of the mode, e.g. model=\"hp1\"")
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
