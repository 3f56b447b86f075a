"""``scenesim rir``: image-source RIRs of a shoebox room, optionally cross-checked against pyroomacoustics.

Writes into ``--out``: ``rir.npy`` (float64 ``(n_mics, n_taps)``) and/or ``rir.wav`` (32-bit
float WAV, one channel per mic), ``rir.json`` (the settings and room), and with
``--compare pyroomacoustics`` also ``crosscheck.json`` and ``crosscheck.png``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from benchmarks.cli.checks import check_cli_fs, options_named, prepare_out_dir
from scenesim.errors import ParameterError
from scenesim.files import write_json_atomic

# The default --rt60-method is only approximate; past this relative miss of the measured
# T30 the user is told to use the calibrated method.
RT60_WARN_REL = 0.10
# Library parameter names -> the options that set them (errors name what was typed).
_OPTIONS = {
    "dims_m": "--dims", "absorption": "--absorption", "rt60_s": "--rt60", "source_m": "--source",
    "mics_m": "--mic", "length_s": "--length", "max_order": "--max-order", "method": "--method",
    "spacing_m": "--spacing", "center_m": "--pair-center",
}
# A source closer than this to a mic makes the 1/(4 pi r) direct path blow up (NaN at r=0).
MIN_SOURCE_MIC_DISTANCE_M = 1e-3

FORMATS = ("npy", "wav", "both")


def add_parser(subparsers):
    p = subparsers.add_parser(
        "rir",
        help="image-source room impulse responses (optionally compared with pyroomacoustics)",
        description="Compute shoebox-room impulse responses by the image-source method.",
    )
    p.add_argument("--dims", nargs=3, type=float, required=True, metavar=("LX", "LY", "LZ"),
                   help="room dimensions in metres")
    wall = p.add_mutually_exclusive_group(required=True)
    wall.add_argument("--absorption", nargs="+", type=float, metavar="A",
                      help="energy absorption in (0, 1]: one value or 6 in the order x=0 x=Lx y=0 y=Ly z=0 z=Lz")
    wall.add_argument("--rt60", type=float, metavar="S", help="target RT60 in seconds")
    p.add_argument("--rt60-method", choices=("sabine", "eyring", "calibrated"), default="sabine",
                   help="how --rt60 becomes an absorption (default sabine)")
    p.add_argument("--source", nargs=3, type=float, required=True, metavar=("X", "Y", "Z"),
                   help="source position in metres")
    mics = p.add_mutually_exclusive_group(required=True)
    mics.add_argument("--mic", nargs=3, type=float, action="append", metavar=("X", "Y", "Z"),
                      help="a mic position in metres (repeat for more mics)")
    mics.add_argument("--pair-center", nargs=3, type=float, metavar=("X", "Y", "Z"),
                      help="centre of a two-mic endfire pair (front mic = channel 0)")
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="pair spacing in metres (default 0.0214)")
    p.add_argument("--pair-azimuth", type=float, default=0.0, metavar="DEG",
                   help="pair axis direction in the horizontal plane, degrees from +x (default 0)")
    p.add_argument("--fs", type=int, default=16000, help="sampling rate in Hz (default 16000)")
    p.add_argument("--max-order", type=int, default=None, metavar="N",
                   help="L1 image order bound (default: all images within the RIR length; "
                        "with --compare: pyroomacoustics' inverse-Sabine order)")
    p.add_argument("--length", type=float, default=None, metavar="S", help="RIR length in seconds")
    p.add_argument("--method", choices=("auto", "exact", "fast"), default="auto",
                   help="renderer (default auto)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--format", choices=FORMATS, default="npy", help="output format (default npy)")
    p.add_argument("--compare", choices=("pyroomacoustics",), default=None,
                   help="also build the room in pyroomacoustics and report the agreement")
    p.set_defaults(func=run)


def pyroomacoustics_max_order(dims_m, rt60_s: float, c: float = 343.0) -> int:
    """pyroomacoustics' ``inverse_sabine`` order: ``ceil(c T / min_pairs(LiLj/sqrt(Li^2+Lj^2)) - 1)``."""
    lx, ly, lz = dims_m
    r = min(a * b / math.hypot(a, b) for a, b in ((lx, ly), (lx, lz), (ly, lz)))
    return int(math.ceil(c * rt60_s / r - 1))


def _check_source_off_mics(source, mics: np.ndarray) -> None:
    """The same rule (and words) as ``simulate``: a source at least 1 mm from every mic."""
    dist = np.linalg.norm(np.atleast_2d(mics) - np.asarray(source, dtype=float), axis=1)
    if np.min(dist) < MIN_SOURCE_MIC_DISTANCE_M:
        raise ParameterError("--source", tuple(source), "a point at least 1 mm from every mic")


def _warn_rt60_miss(h: np.ndarray, fs: int, args) -> None:
    """Warn when the measured T30 misses --rt60 by more than 10 % (uncalibrated methods only)."""
    from scenesim.rt60 import measure_rt60

    if args.rt60 is None or args.rt60_method == "calibrated":
        return
    try:
        t30 = float(np.mean(measure_rt60(h, fs, method="T30")))
    except ParameterError:  # too short a RIR to fit T30: nothing to compare
        return
    miss = t30 / args.rt60 - 1.0
    if abs(miss) > RT60_WARN_REL:
        warnings.warn(
            f"the measured T30 of this RIR is {t30:.3f} s, {100 * miss:+.0f} % off --rt60 {args.rt60:g} s "
            f"(--rt60-method {args.rt60_method} is an approximation); use --rt60-method calibrated "
            f"for a room whose measured T30 matches",
            stacklevel=2,
        )


def run(args) -> int:
    from scenesim.geometry import DEFAULT_SPACING_M, MicPair
    from scenesim.ism import image_source_rir
    from scenesim.room import ShoeBox

    check_cli_fs("--fs", args.fs)
    out = prepare_out_dir("--out", args.out)
    absorption = None
    if args.absorption is not None:
        if len(args.absorption) not in (1, 6):
            raise ParameterError("--absorption", args.absorption, "1 or 6 values")
        absorption = args.absorption[0] if len(args.absorption) == 1 else tuple(args.absorption)
    with options_named(_OPTIONS):
        room = ShoeBox(tuple(args.dims), absorption, rt60_s=args.rt60, rt60_method=args.rt60_method)
    if args.pair_center is not None:
        spacing = DEFAULT_SPACING_M if args.spacing is None else args.spacing
        with options_named(_OPTIONS):
            mics = MicPair(tuple(args.pair_center), spacing, args.pair_azimuth).positions_m
    else:
        if args.spacing is not None:
            raise ParameterError("--spacing", args.spacing, "--spacing only together with --pair-center")
        mics = np.asarray(args.mic, dtype=float)
    if args.format not in FORMATS:
        raise ParameterError("format", args.format, "one of " + ", ".join(FORMATS))
    _check_source_off_mics(args.source, mics)
    # The saved RIR depends only on the user's settings; --compare picks its own order for
    # the comparison and must not change what is written.
    max_order = args.max_order
    with options_named(_OPTIONS):
        h = image_source_rir(
            room, args.source, mics, fs=args.fs, max_order=max_order, length_s=args.length,
            method=args.method,
        )
    if not np.all(np.isfinite(h)):
        raise ParameterError("--source/--mic", tuple(args.source), "positions giving a finite RIR")
    _warn_rt60_miss(h, args.fs, args)
    written = []
    if args.format in ("npy", "both"):
        np.save(out / "rir.npy", h)
        written.append(out / "rir.npy")
    if args.format in ("wav", "both"):
        import soundfile as sf

        sf.write(out / "rir.wav", h.T, args.fs, subtype="FLOAT")
        written.append(out / "rir.wav")
    meta = {
        "dims_m": list(room.dims_m),
        "wall_absorption": room.wall_absorption.tolist(),
        "rt60_s": room.rt60_s,
        "rt60_method": room.rt60_method,
        "sabine_rt60_s": room.sabine_rt60_s,
        "source_m": list(map(float, args.source)),
        "mics_m": mics.tolist(),
        "fs": args.fs,
        "max_order": max_order,
        "n_taps": int(h.shape[1]),
        "method": args.method,
        "time_origin": "tap 0 = emission, no global delay",
    }
    write_json_atomic(out / "rir.json", meta)
    written.append(out / "rir.json")
    print(f"RIR {h.shape[0]} mic(s) x {h.shape[1]} taps at {args.fs} Hz; "
          f"wall absorption {np.round(room.wall_absorption, 4).tolist()}")
    if args.compare:
        from scenesim.crosscheck import compare_with_pyroomacoustics, plot_crosscheck

        compare_order = max_order
        if compare_order is None:
            compare_order = pyroomacoustics_max_order(room.dims_m, room.nominal_rt60_s, room.c)
        check = compare_with_pyroomacoustics(
            room, args.source, mics, fs=args.fs, max_order=compare_order, method=args.method
        )
        write_json_atomic(out / "crosscheck.json", check.to_dict())
        plot_crosscheck(check, path=out / "crosscheck.png")
        written += [out / "crosscheck.json", out / "crosscheck.png"]
        print(f"pyroomacoustics 0.10.1 cross-check (max_order {compare_order}, {check.n_images} images):")
        print(f"  rel L2 per mic      {', '.join(f'{v:.2e}' for v in check.rel_l2)}")
        print(f"  argmax equal        {check.argmax_equal}")
        err = check.inter_mic_delay_error_samples
        if err == err:  # NaN with a single mic: there is no inter-mic delay to compare
            print(f"  inter-mic delay err {err:.2e} samples")
        else:
            print("  inter-mic delay err n/a (needs two or more mics)")
        print(f"  T30 ours / theirs   {check.t30_ours_s:.3f} s / {check.t30_theirs_s:.3f} s "
              f"(target {check.target_rt60_s:.3f} s; theirs off by {100 * check.their_rt60_error:+.1f} %)")
    for path in written:
        print(f"wrote {path}")
    return 0
