"""Which of ``eb-spp``'s adaptive quantities moves the talker's path (speech jitter by source).

    python -m benchmarks.studies.jitter_sources [--split dev] [--seeds 2] [--first-seed 0]
        [--snr 25] [--data-dir DIR] [--set KEY=JSON ...]

Speech jitter (:func:`benchmarks.metrics.distortion.speech_jitter_db`) compares the talker's path
through the two operations of Hagerman's pair: ``W1`` (adapted to ``s + n``) and ``W2`` (to
``s - n``).  ``eb-spp``'s operation per frame and bin is set by three adaptive quantities: beta,
the delay-and-sum weight alpha and the rear mic's response ``r_hat`` (:mod:`enhancers.beam.spp_eb`)::

    w = [(1 - alpha) G (a - beta b) + alpha s] with its rear entry divided by r_hat

This script runs both mixtures of each ``phone`` condition (the preset's scenes at one input SNR,
every noise, seeds ``S ..``) and replays the talker through four operations built from run 2's
quantities: all three (the measured jitter) and each one alone with the other two from run 1.
The jitter of "one alone" is what that quantity's difference between the runs costs the talker;
the three need not add up (the operation is not linear in them).  Also printed: the jitter per
band (below 300 Hz, 300 Hz-1 kHz, 1-3 kHz, above), as the share of the talker's output power.

Why it matters: with the look constraint on the axis (``a``, ``b``, ``s`` designed for an endfire
talker), a talker off the axis -- 45 deg in ``phone`` -- reaches the backward cardioid and the
two paths with different responses, so any change of beta, alpha or ``r_hat`` moves it.
Measured (``python -m benchmarks.studies.jitter_sources``: dev split, built-in data, seeds 0-1, 25 dB,
8 conditions, ``eb-spp`` v3): alpha alone -21.8 ... -43.5 dB, ``r_hat`` alone -32.4 ... -38.5 dB,
beta alone -26.9 ... -56.9 dB, all three -19.7 ... -37.0 dB; per band the jitter lies below 1 kHz
(-18.7 ... -48.9 dB there against -38.1 ... -52.7 dB above), where the equaliser's gain is large.
With ``--set 'spp="single"'`` (v2's SPP): alpha alone -22.4 ... -44.8, ``r_hat`` -33.0 ... -37.4,
beta -35.5 ... -56.3, all three -18.8 ... -36.7 dB.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.metrics.distortion import speech_jitter_db
from benchmarks.run import worker
from benchmarks.run.sweep import load_sweep
from benchmarks.studies.noise_stats import parse_sets

BANDS_HZ = ((0.0, 300.0), (300.0, 1000.0), (1000.0, 3000.0), (3000.0, np.inf))
SOURCES = ("beta", "alpha", "r_hat")


def operation(enhancer, fs: int, beta, alpha, r_hat) -> np.ndarray:
    """``eb-spp``'s weights ``(F, K, 2)`` on the uncalibrated spectra from beta, alpha ``(F, K)`` and
    ``r_hat`` ``(F, K)`` complex (the module docstring's formula; ``enhancers.beam.spp_eb``'s steps 2-4).

    >>> import enhancers, numpy as np
    >>> e = enhancers.make("eb-spp")
    >>> z = np.zeros((1, 129))
    >>> w = operation(e, 16000, z, z, np.ones((1, 129), complex))   # the fixed cardioid, calibrated
    >>> bool(np.allclose(w[0, 60], e._constants(16000)[1][60] * np.array([1.0, -e._constants(16000)[0][60]])))
    True
    """
    e, G, look, _, _ = enhancer._constants(fs)  # the enhancer's own constants: one definition of the design
    a = np.stack([np.ones_like(e), -e], axis=-1)
    b = np.stack([-e, np.ones_like(e)], axis=-1)
    s = (0.5 * look)[:, None] * np.stack([e, np.ones_like(e)], axis=-1)
    d = G[:, None] * (a - np.asarray(beta)[..., None] * b)
    w = d - np.asarray(alpha)[..., None] * (d - s)
    return np.stack([w[..., 0], w[..., 1] / np.asarray(r_hat)], axis=-1)


def _r_hat(trace) -> np.ndarray:
    return 10.0 ** (trace["rear_gain_db"] / 20.0) * np.exp(1j * np.radians(trace["rear_phase_deg"]))


def _quantities(trace) -> dict[str, np.ndarray]:
    return {"beta": trace["beta"], "alpha": trace["alpha"], "r_hat": _r_hat(trace)}


def _replay(enhancer, fs, w, S, n):
    fb = enhancer.filterbank
    Y = w[..., 0] * S[0] + w[..., 1] * S[1]
    return fb.synthesize(Y[None], n)


def _band_shares(enhancer, fs, w1, w2, S) -> list[float]:
    """Jitter per band in dB re the talker's whole output power (STFT domain)."""
    y1 = w1[..., 0] * S[0] + w1[..., 1] * S[1]
    d = np.abs((w1 - w2)[..., 0] * S[0] + (w1 - w2)[..., 1] * S[1]) ** 2
    f = np.arange(S.shape[2]) * fs / enhancer.filterbank.frame_len
    total = np.sum(np.abs(y1) ** 2)
    return [10 * np.log10(max(d[:, (f >= lo) & (f < hi)].sum() / total, 1e-30)) for lo, hi in BANDS_HZ]


def condition_sources(enhancer, cond, data_dir) -> dict[str, object]:
    """The jitter of each source alone, of all three, and per band, for one condition."""
    images, _, _ = worker.render_group(cond, data_dir)
    r = images.mix(cond.snr_db)
    s, n = np.asarray(r.speech_image, float), np.asarray(r.noise_image, float)
    q1 = _quantities(enhancer.process(s + n, cond.fs).trace)
    q2 = _quantities(enhancer.process(s - n, cond.fs).trace)
    S = enhancer.filterbank.analyze(s)
    w1 = operation(enhancer, cond.fs, **q1)
    y1 = _replay(enhancer, cond.fs, w1, S, s.shape[1])
    out: dict[str, object] = {}
    w_all = operation(enhancer, cond.fs, **q2)
    out["all"] = speech_jitter_db(y1, _replay(enhancer, cond.fs, w_all, S, s.shape[1]))
    for name in SOURCES:
        w = operation(enhancer, cond.fs, **{**q1, name: q2[name]})
        out[name] = speech_jitter_db(y1, _replay(enhancer, cond.fs, w, S, s.shape[1]))
    out["bands"] = _band_shares(enhancer, cond.fs, w1, w_all, S)
    return out


def main(argv=None) -> int:
    from enhancers.core.registry import make, with_geometry

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="dev", choices=("dev", "test", "all"), help="data split (default dev)")
    ap.add_argument("--seeds", type=int, default=2, help="number of seeds (default 2)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--snr", type=float, default=25.0, help="input SNR in dB (default 25)")
    ap.add_argument("--data-dir", default=None, help="speech/noise directory (default: built-in data)")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=JSON", help="an eb-spp parameter")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0:
        ap.error(f"--seeds {args.seeds} / --first-seed {args.first_seed}: need seeds >= 1 and first seed >= 0")
    try:
        params = parse_sets([f"eb-spp.{item}" for item in args.set]).get("eb-spp", {})
    except ValueError as e:
        ap.error(str(e))
    sweep = load_sweep("phone").with_split(args.split).with_seeds(args.seeds)
    sweep = sweep.with_seed(args.first_seed) if args.first_seed else sweep
    print("| noise | seed | all three | beta alone | alpha alone | r_hat alone | "
          + " | ".join(f"band {lo:g}-{hi:g} Hz" for lo, hi in BANDS_HZ) + " |")
    print("| --- | ---: |" + " ---: |" * (4 + len(BANDS_HZ)))
    for cond in sweep.conditions():
        if cond.snr_db != args.snr:
            continue
        enhancer = with_geometry(make("eb-spp", **params), spacing_m=cond.spacing_m, c_mps=worker.SPEED_OF_SOUND_MPS)
        out = condition_sources(enhancer, cond, args.data_dir)
        cells = [f"{out[k]:.1f}" for k in ("all", *SOURCES)] + [f"{v:.1f}" for v in out["bands"]]
        print(f"| {cond.noise} | {cond.seed} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
