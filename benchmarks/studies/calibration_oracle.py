"""Issue 16 part 3's bound: how talker-blind can ``eb-robust`` be if it learns only where the talker is absent?

    python -m benchmarks.studies.calibration_oracle [--data-dir DIR] [--seeds N] [--snrs 15 20 25]
        [--threshold-db -40 ...] [--scope all | calibration] [--set KEY=JSON ...] [--mismatch-seeds N]

An *analysis instrument*, never a system: it gives ``eb-robust`` an ORACLE learning mask computed from
the true speech and noise images -- a cell (frame, bin) may be learned from only where the talker's
power over both mics is at least ``-threshold_db`` below the noise's (``rho = |S|^2 / |N|^2 <
10^(threshold/10)``) -- and measures on ``phone`` what :mod:`benchmarks.studies.calibration_jitter`
measures (jitter, replay SNR-I) plus the fraction of cells learned, and issue 12's mismatch loss in
:mod:`benchmarks.studies.robust_eb`'s scene.  No enhancer in a sweep sees the mask.

How: inside :func:`oracle_learning` (which runs the numpy step, not the compiled one), the calibration's
freeze rules (:func:`enhancers.beam.mic_calibration._freeze`) return the oracle's cells, and the beamformer's
beta and DAS weight are frozen on the same cells, with beta's own gate off (``adapt_gate_db=None``): the
calibration, beta and the DAS weight learn on exactly the oracle's cells (``--scope all``).  ``--scope
calibration``: only the calibration does; beta and the DAS weight keep their own gate.

Why it matters.  In cells where the talker is absent the runs on ``s + n`` and ``s - n`` are the same
up to sign, so a rule that learned only there would give ``W1 = W2`` (the issue's premise).  The
oracle says what such a rule could reach at best, and at which threshold: the speech x noise cross
term of a learned cell is ``~2 sqrt(rho)`` of its noise, and the estimate's difference between the runs
``~ sqrt(sum rho_i) / K`` over the ``K`` cells it pools, amplified at low frequencies by the
differential pair's ``1 / (2 w T)``.

Measured (shared data = ``../shared/data``, 2 seeds, 15-25 dB, ``ramp_frames=40`` counted over the
averaging band -- today's ramp counts the bin's own frames, so a rerun differs a little --, this module's
defaults otherwise; 2 cores, load ~2): at -20 dB the worst ``eb-robust`` row is -15.6 dB, at -40 dB every row is
<= -32 dB; with ``mix_alpha0=1`` also the SNR-I per noise is within 1 dB of the default (wind +2.8 dB),
and the mismatch loss is <= 0.2 dB (the built-in voice's pauses suffice).  Blind rules learn 0-3 % of
the cells in babble and factory where the -40 dB oracle finds 8-10 %.

``--frame``: the decision per *frame* (talker-to-noise power over 125 Hz-4 kHz, every bin alike), the one
the frame rule of :mod:`enhancers.beam.mic_calibration` makes blind.
"""

from __future__ import annotations

import argparse
import contextlib
import json

import numpy as np

import enhancers
import enhancers.beam.mic_calibration as mc
import enhancers.beam.subband_eb as sb
from benchmarks.run.sweep import load_sweep
from benchmarks.studies import calibration_jitter as cj
from benchmarks.studies import robust_eb as rb
from enhancers.kernels import frames as fast_frames

#: what the oracle switches off so that its mask is the only rule (and the one beta and the DAS weight use)
ORACLE_PARAMS = {"adapt_gate_db": None}
#: ``--scope calibration``: beta and the DAS weight keep their own gate
CALIBRATION_ONLY = {"adapt_gate_db": 3.0}


#: ``--frame``: the band over which a frame's talker-to-noise ratio is taken (Hz)
FRAME_BAND_HZ = (125.0, 4000.0)


def oracle_mask(speech: np.ndarray, noise: np.ndarray, filterbank, threshold_db: float, *,
                frame: bool = False, fs: int = 16000) -> np.ndarray:
    """``(F, K)`` bool, True where a cell must NOT be learned: talker-to-noise power over the mics at or
    above ``threshold_db`` (``speech``, ``noise``: ``(2, n)`` images; ``filterbank``: the enhancer's);
    ``frame``: per frame, the powers summed over :data:`FRAME_BAND_HZ`, every bin of the frame alike (the
    decision the frame rule of :mod:`enhancers.beam.mic_calibration` makes blind; ``fs``: the sample rate, Hz).

    >>> import numpy as np
    >>> from enhancers.core.filterbank import FilterBank
    >>> rng = np.random.default_rng(0)
    >>> s = np.zeros((2, 4096)); s[:, 2048:] = 0.1 * rng.standard_normal((2, 2048))   # -20 dB from 2048 on
    >>> n = rng.standard_normal((2, 4096))
    >>> m = oracle_mask(s, n, FilterBank(frame_len=256, hop=128), -40.0)
    >>> bool(m[:12].any()), bool(m[18:30].all())   # the silence is learned, the -20 dB talker is not
    (False, True)
    >>> bool(oracle_mask(s, n, FilterBank(frame_len=256, hop=128), 0.0)[18:30].any())  # nor at 0 dB
    False
    >>> m = oracle_mask(s, n, FilterBank(frame_len=256, hop=128), -30.0, frame=True)
    >>> bool(m[18:30].all()), bool(m[:12].any())   # per frame: every bin of the talker's frames
    (True, False)
    """
    S, N = filterbank.analyze(speech), filterbank.analyze(noise)
    ps = (S.real**2 + S.imag**2).sum(axis=0)
    pn = (N.real**2 + N.imag**2).sum(axis=0)
    if frame:
        f = np.fft.rfftfreq(2 * (ps.shape[1] - 1), 1.0 / fs)
        band = (f >= FRAME_BAND_HZ[0]) & (f <= FRAME_BAND_HZ[1])
        ps, pn = (np.broadcast_to(p[:, band].sum(axis=1, keepdims=True), p.shape) for p in (ps, pn))
    return ps >= pn * 10.0 ** (threshold_db / 10.0)


@contextlib.contextmanager
def oracle_learning(mask: np.ndarray, *, calibration_only: bool = False):
    """Within the block, :func:`enhancers.beam.mic_calibration._freeze` returns ``mask``'s rows for the frames
    it is asked about (counted from each stream's start), and the sub-band beamformer's beta and DAS weight
    are frozen on the same rows (``calibration_only``: they keep their own gate); the numpy step runs (the
    compiled one has no such hook)."""
    original, beamform, compiled = mc._freeze, sb.SubbandBase._beamform, fast_frames.COMPILED

    def frozen(X1, X2, state, p, *, fs, delay, band):
        _, changes = original(X1, X2, state, p, fs=fs, delay=delay, band=band)
        return mask[state.n_frames:state.n_frames + X1.shape[0]].copy(), changes

    def oracle_beamform(self, X1, X2, sub, fs, mix_frozen=None, beta_frozen=None, mix_learn=None):
        rows = None if calibration_only else mask[sub.frames:sub.frames + X1.shape[0]].copy()
        return beamform(self, X1, X2, sub, fs, mix_frozen=rows, beta_frozen=rows, mix_learn=mix_learn)

    mc._freeze, sb.SubbandBase._beamform, fast_frames.COMPILED = frozen, oracle_beamform, False
    try:
        yield
    finally:
        mc._freeze, sb.SubbandBase._beamform, fast_frames.COMPILED = original, beamform, compiled


def oracle_params(scope: str, overrides=None) -> dict:
    """``eb-robust``'s parameters under the oracle (``scope``: ``"all"`` or ``"calibration"``)."""
    return {**ORACLE_PARAMS, **(CALIBRATION_ONLY if scope == "calibration" else {}), **(overrides or {})}


def phone_oracle_rows(data_dir, *, seeds: int, snrs, threshold_db: float, params: dict,
                      scope: str = "all", frame: bool = False, ss=None) -> list[dict]:
    """:func:`benchmarks.studies.calibration_jitter.measure_condition`'s rows under the oracle (``scope``:
    ``"all"`` or ``"calibration"``), plus ``learned`` (the fraction of cells the mask leaves open)."""
    fb = enhancers.make("eb-robust", **params).filterbank
    rows = []
    for cond in load_sweep("phone").conditions():
        if cond.seed >= seeds or (snrs and cond.snr_db not in snrs):
            continue
        parts = cj.render_parts(cond, data_dir)
        mask = oracle_mask(parts[0], parts[1], fb, threshold_db, frame=frame, fs=cond.fs)
        with oracle_learning(mask, calibration_only=scope == "calibration"):
            new = cj.measure_condition(cond, data_dir, overrides=params, parts=parts, ss=ss)
        rows += [{**r, "learned": float(1.0 - mask.mean())} for r in new]
    return rows


def mismatch_losses(seed: int, threshold_db: float, params: dict, scope: str = "all",
                    frame: bool = False) -> dict[str, tuple[float, float]]:
    """Issue 12's scene (:func:`benchmarks.studies.robust_eb.snr_improvements`' conditions) under the oracle:
    ``{noise: (ideal SNR-I, mismatched SNR-I)}`` (dB, scored after 8 s of 20 s)."""
    start, out = int(8.0 * rb.FS), {}
    for kind in ("135", "240", "diffuse", "wind"):
        s0, v0 = rb._scene(kind, 20.0, seed)
        res = []
        for gain_db, phase_deg in ((0.0, 0.0), (1.0, 5.0)):
            s, v = (rb.rear_mismatch(c, gain_db=gain_db, phase_deg=phase_deg) for c in (s0, v0))
            e = enhancers.make("eb-robust", **params)
            with oracle_learning(oracle_mask(s, v, e.filterbank, threshold_db, frame=frame, fs=rb.FS),
                                 calibration_only=scope == "calibration"):
                res.append(rb.replay_snr_i(e, s, v, start))
        out[kind] = (res[0], res[1])
    return out


def print_rows(rows, threshold_db: float) -> None:
    print(f"\noracle threshold {threshold_db:g} dB: per noise, worst / median speech_jitter_db, mean replay SNR-I, "
          "cells learned\n")
    print("| system | noise | worst jitter | median | SNR-I | learned |\n| --- | --- | ---: | ---: | ---: | ---: |")
    for (name, noise), g in sorted(cj._group(rows, "system", "noise").items()):
        j = [r["jitter"] for r in g]
        print(f"| {name} | {noise} | {max(j):.1f} | {np.median(j):.1f} | {np.mean([r['replay'] for r in g]):.2f} | "
              f"{np.mean([r['learned'] for r in g]):.1%} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=None, help="real recordings (default: the built-in synthetic data)")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--snrs", type=float, nargs="*", default=[15.0, 20.0, 25.0])
    ap.add_argument("--threshold-db", type=float, nargs="*", default=[-40.0])
    ap.add_argument("--scope", choices=("all", "calibration"), default="all")
    ap.add_argument("--set", nargs="*", default=["ramp_frames=40"], metavar="KEY=JSON",
                    help="eb-robust parameters on top of the oracle's (default: the start-up ramp)")
    ap.add_argument("--mismatch-seeds", type=int, default=0, help="issue 12's scene, seeds 3, 13, ... (0: skip)")
    ap.add_argument("--frame", action="store_true",
                    help="a frame-level oracle: the talker-to-noise ratio over 125 Hz-4 kHz decides the whole frame")
    args = ap.parse_args(argv)
    try:
        params = oracle_params(args.scope, cj.parse_set(args.set))
    except ValueError as e:
        ap.error(str(e))  # one line and the usage, exit status 2
    print(f"phone, data: {args.data_dir or 'built-in'}, seeds 0..{args.seeds - 1}, SNRs {args.snrs}, "
          f"scope {args.scope}, eb-robust {json.dumps(params)}")
    for thr in args.threshold_db:
        print_rows(phone_oracle_rows(args.data_dir, seeds=args.seeds, snrs=args.snrs, threshold_db=thr,
                                     params=params, scope=args.scope, frame=args.frame), thr)
        for k in range(args.mismatch_seeds):
            losses = mismatch_losses(3 + 10 * k, thr, params, args.scope, frame=args.frame)
            print(f"\nmismatch scene, seed {3 + 10 * k}: " + "; ".join(
                f"{kind} ideal {a:.1f} / mismatched {b:.1f} (loss {a - b:.1f})" for kind, (a, b) in losses.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
