"""``scenesim rir``: image-source RIRs of a shoebox room, optionally cross-checked against pyroomacoustics.

Writes into ``--out``: ``rir.npy`` (float64 ``(n_mics, n_taps)``) and/or ``rir.wav`` (32-bit
float WAV, one channel per mic), ``rir.json`` (the settings and room), and with
``--compare pyroomacoustics`` also ``crosscheck.json`` and ``crosscheck.png``.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np

from benchmarks.cli.checks import check_cli_fs, options_named, prepare_out_dir
from scenesim.errors import ParameterError
from scenesim.files import write_json_atomic
from scenesim.validate import check_physical

# Sabine's and Eyring's formulas (opt-in --rt60-method) are approximate; past this relative miss of
# the measured T30 the user is told to use the calibrated method (the default).
RT60_WARN_REL = 0.10
# Library parameter names -> the options that set them (errors name what was typed).
_OPTIONS = {
    "dims_m": "--dims", "absorption": "--absorption", "rt60_s": "--rt60", "source_m": "--source",
    "mics_m": "--mic", "length_s": "--length", "max_order": "--max-order", "method": "--method",
    "spacing_m": "--spacing", "center_m": "--pair-center", "scattering": "--scattering", "p": "--directivity-p",
}

FORMATS = ("npy", "wav", "both")


def add_parser(subparsers):
    p = subparsers.add_parser(
        "rir",
        help="image-source room impulse responses (optionally compared with pyroomacoustics)",
        description="Compute shoebox-room impulse responses by the image-source method.",
    )
    _add_room_args(p)
    _add_placement_args(p)
    _add_render_args(p)
    p.set_defaults(func=run)


def _add_room_args(p) -> None:
    """The room: dimensions, walls (absorption or RT60 targets), scattering and air."""
    p.add_argument("--dims", nargs=3, type=float, required=True, metavar=("LX", "LY", "LZ"),
                   help="room dimensions in metres")
    wall = p.add_mutually_exclusive_group(required=True)
    wall.add_argument("--absorption", nargs="+", type=float, metavar="A",
                      help="energy absorption in (0, 1]: one value or 6 in the order x=0 x=Lx y=0 y=Ly z=0 z=Lz")
    wall.add_argument("--rt60", type=float, metavar="S", help="target RT60 in seconds")
    wall.add_argument("--band-absorption", nargs="+", type=float, metavar="A",
                      help="octave-band absorption at 125 Hz..8 kHz: 7 values (every wall) or 42 "
                           "(6 walls x 7 bands, wall by wall)")
    wall.add_argument("--band-rt60", nargs=7, type=float, metavar="S",
                      help="target T30 per octave 125 Hz..8 kHz (calibrated per band)")
    p.add_argument("--rt60-method", choices=("sabine", "eyring", "calibrated"), default="calibrated",
                   help="how --rt60 becomes an absorption: calibrated (default; the measured T30 of the RIR "
                        "matches, as in scenesim.calibrate_room and every sweep), or Sabine's / Eyring's "
                        "formula (fast, off by -20..+90 %% in non-cubic rooms)")
    p.add_argument("--scattering", type=float, default=None, metavar="S",
                   help="wall scattering coefficient in [0, 1) (diffuse reflections, scenesim.room.scattering); "
                        "default 0.5 with --rt60-method calibrated / --band-rt60, else 0 (specular)")
    p.add_argument("--air", action="store_true",
                   help="add ISO 9613-1 air absorption (see --temperature, --humidity)")
    p.add_argument("--temperature", type=float, default=20.0, metavar="C",
                   help="air temperature in degrees Celsius for --air (default 20)")
    p.add_argument("--humidity", type=float, default=50.0, metavar="PCT",
                   help="relative humidity in %% for --air (default 50)")


def _add_placement_args(p) -> None:
    """Where the source and the mics are."""
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


def _add_render_args(p) -> None:
    """How the RIR is rendered and written, and the source's directivity."""
    p.add_argument("--fs", type=int, default=16000, help="sampling rate in Hz (default 16000)")
    p.add_argument("--max-order", type=int, default=None, metavar="N",
                   help="L1 image order bound of the specular images (default: all within the RIR length; "
                        "with --compare: pyroomacoustics' inverse-Sabine order); the scattered tail of a room "
                        "with --scattering > 0 is not made of images: --scattering 0 for an order-limited RIR")
    p.add_argument("--highpass", type=float, default=20.0, metavar="HZ",
                   help="causal 2nd-order Butterworth high-pass of the RIR in Hz (default 20, as every "
                        "rendered scene; 0 = the raw image sum)")
    p.add_argument("--length", type=float, default=None, metavar="S", help="RIR length in seconds")
    p.add_argument("--method", choices=("auto", "exact", "fast", "hybrid"), default="auto",
                   help="renderer (default auto); hybrid = images up to --mixing-time, then a "
                        "stochastic tail with the ISM's decay and diffuse coherence")
    p.add_argument("--mixing-time", type=float, default=None, metavar="S",
                   help="hybrid only: end of the image-source part in seconds (default 0.08)")
    p.add_argument("--seed", type=int, default=None,
                   help="hybrid only: seed of the tail (default: derived from the positions)")
    p.add_argument("--directivity", choices=("omni", "cardioid-family", "talker"), default="omni",
                   help="source directivity: cardioid-family (p + (1-p) cos, --directivity-p) or "
                        "talker (front/back ratio rising with frequency, per octave)")
    p.add_argument("--directivity-p", type=float, default=None, metavar="P",
                   help="cardioid-family p: 1 omni, 0.5 cardioid (default), 0.25 hypercardioid, 0 figure-eight")
    p.add_argument("--source-azimuth", type=float, default=0.0, metavar="DEG",
                   help="directivity axis, degrees from +x towards +y (default 0)")
    p.add_argument("--source-elevation", type=float, default=0.0, metavar="DEG",
                   help="directivity axis elevation in degrees (default 0)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--format", choices=FORMATS, default="npy", help="output format (default npy)")
    p.add_argument("--compare", choices=("pyroomacoustics",), default=None,
                   help="also build the room in pyroomacoustics and report the agreement")


def pyroomacoustics_max_order(dims_m, rt60_s: float, c: float = 343.0) -> int:
    """pyroomacoustics' ``inverse_sabine`` order: ``ceil(c T / min_pairs(LiLj/sqrt(Li^2+Lj^2)) - 1)``."""
    lx, ly, lz = dims_m
    r = min(a * b / math.hypot(a, b) for a, b in ((lx, ly), (lx, lz), (ly, lz)))
    return int(math.ceil(c * rt60_s / r - 1))


def _warn_rt60_miss(h: np.ndarray, fs: int, args) -> None:
    """Warn when the measured T30 misses --rt60 by more than 10 % (uncalibrated methods only)."""
    from scenesim.room.rt60 import measure_rt60

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


def _check_physical_room(args) -> None:
    """--rt60 and --dims within the shared physical ranges; a slow render is announced (as
    ``bench run`` does) unless the hybrid tail or an explicit --length/--max-order bounds it."""
    from benchmarks.run.progress import SLOW_RIR_WARN_S, estimated_rir_seconds

    for value in args.dims:
        check_physical("--dims", value, "room_dim_m")
    if args.rt60 is None:
        return
    check_physical("--rt60", args.rt60, "rt60_s")
    est = estimated_rir_seconds(args.rt60, math.prod(args.dims))
    if args.method != "hybrid" and args.length is None and args.max_order is None and est > SLOW_RIR_WARN_S:
        warnings.warn(
            f"RT60 {args.rt60:g} s in this {math.prod(args.dims):.0f} m^3 room will take about {est / 60:.0f} min "
            f"to render (image sources to the full decay); --method hybrid or --length shorten it",
            stacklevel=2,
        )


def run(args) -> int:
    check_cli_fs("--fs", args.fs)
    _check_physical_room(args)
    out = prepare_out_dir("--out", args.out)
    if args.format not in FORMATS:
        raise ParameterError("format", args.format, "one of " + ", ".join(FORMATS))
    with options_named(_OPTIONS):
        room = _build_room(args, _absorption(args))
    mics = _mics(args)
    directivity = _directivity(args)
    # The saved RIR depends only on the user's settings; --compare picks its own order for
    # the comparison and must not change what is written.
    h = _render(args, room, mics, directivity)
    _warn_rt60_miss(h, args.fs, args)
    written = _save_rir(out, h, args.fs, args.format)
    meta = _rir_meta(args, room, mics, h, directivity)
    write_json_atomic(out / "rir.json", meta)
    written.append(out / "rir.json")
    print(f"RIR {h.shape[0]} mic(s) x {h.shape[1]} taps at {args.fs} Hz; "
          f"wall absorption {np.round(room.wall_absorption, 4).tolist()}")
    if args.compare:
        # --compare uses pyroomacoustics' inverse-Sabine order unless --max-order was given.
        order = args.max_order
        if order is None:
            order = pyroomacoustics_max_order(room.dims_m, room.nominal_rt60_s, room.c)
        if room.is_flat:
            written += _compare_flat(args, room, mics, order, directivity, h, out)
        else:
            written += _compare_bands(room, args, mics, order, out)
    for path in written:
        print(f"wrote {path}")
    return 0


def _absorption(args):
    """``--absorption``: None, one value or one per wall."""
    if args.absorption is None:
        return None
    if len(args.absorption) not in (1, 6):
        raise ParameterError("--absorption", args.absorption, "1 or 6 values")
    return args.absorption[0] if len(args.absorption) == 1 else tuple(args.absorption)


def _mics(args) -> np.ndarray:
    """Mic positions ``(n_mics, 3)`` in m: ``--pair-center`` (with ``--spacing``) or ``--mic``."""
    from scenesim.scene.geometry import DEFAULT_SPACING_M, MicPair

    if args.pair_center is not None:
        spacing = DEFAULT_SPACING_M if args.spacing is None else args.spacing
        with options_named(_OPTIONS):
            return MicPair(tuple(args.pair_center), spacing, args.pair_azimuth).positions_m
    if args.spacing is not None:
        raise ParameterError("--spacing", args.spacing, "--spacing only together with --pair-center")
    return np.asarray(args.mic, dtype=float)


def _render(args, room, mics, directivity) -> np.ndarray:
    """The RIR ``(n_mics, n_taps)`` the flags ask for; a non-finite one is refused."""
    from scenesim.room.render import room_rir

    hybrid_kw = {"mixing_time_s": args.mixing_time, "seed": args.seed} if args.method == "hybrid" else {}
    with options_named(_OPTIONS):
        h = room_rir(
            room, args.source, mics, fs=args.fs, max_order=args.max_order, length_s=args.length,
            method=args.method, highpass_hz=args.highpass if args.highpass else None,
            directivity=directivity, **hybrid_kw,
        )
    if not np.all(np.isfinite(h)):
        raise ParameterError("--source/--mic", tuple(args.source), "positions giving a finite RIR")
    return h


def _save_rir(out: Path, h: np.ndarray, fs: int, fmt: str) -> list[Path]:
    """``rir.npy`` and/or ``rir.wav`` (float, one channel per mic); the paths written."""
    written = []
    if fmt in ("npy", "both"):
        np.save(out / "rir.npy", h)
        written.append(out / "rir.npy")
    if fmt in ("wav", "both"):
        import soundfile as sf

        sf.write(out / "rir.wav", h.T, fs, subtype="FLOAT")
        written.append(out / "rir.wav")
    return written


def _rir_meta(args, room, mics, h, directivity) -> dict:
    """``rir.json``: the room, the geometry, the render settings and the ISO 3382 parameters."""
    hybrid = args.method == "hybrid"
    meta = {
        "dims_m": list(room.dims_m),
        "wall_absorption": room.wall_absorption.tolist(),
        "scattering": room.scattering,
        "rt60_s": args.rt60,
        "rt60_method": args.rt60_method if args.rt60 is not None else None,
        "sabine_rt60_s": np.asarray(room.sabine_rt60_s).tolist(),
        "source_m": list(map(float, args.source)),
        "mics_m": mics.tolist(),
        "fs": args.fs,
        "max_order": args.max_order,
        "n_taps": int(h.shape[1]),
        "method": args.method,
        "mixing_time_s": args.mixing_time if hybrid else None,
        "seed": args.seed if hybrid else None,
        "directivity": None if directivity is None else {
            "kind": args.directivity, "coefficients": directivity.coefficients,
            "bands_hz": directivity.bands_hz, "azimuth_deg": directivity.azimuth_deg,
            "elevation_deg": directivity.elevation_deg,
        },
        "time_origin": "tap 0 = emission, no global delay",
    }
    meta.update(_band_meta(room))
    meta["highpass_hz"] = args.highpass if args.highpass else None
    meta["iso3382"] = _iso3382(room, args, mics, h, directivity)
    return meta


def _compare_flat(args, room, mics, order, directivity, h, out: Path) -> list[Path]:
    """The omni (flat-absorption) cross-check against pyroomacoustics, plus directivity, hybrid and
    scattering where they apply; ``crosscheck.json``/``.png`` and the lines printed."""
    from scenesim.room.crosscheck import compare_with_pyroomacoustics, plot_crosscheck

    # The omni comparison uses the full ISM: a hybrid tail is stochastic by design.
    method = "auto" if args.method == "hybrid" else args.method
    # pyroomacoustics' ISM is specular: compare the specular part; scattering below.
    specular = dataclasses.replace(room, scattering=None)
    check = compare_with_pyroomacoustics(specular, args.source, mics, fs=args.fs, max_order=order, method=method)
    numbers = check.to_dict()
    _print_flat_check(check, order)
    if directivity is not None:
        numbers["directivity"] = _compare_directivity(args, room, mics, order, directivity)
    if args.method == "hybrid":
        numbers["hybrid"] = _compare_hybrid(args, room, mics, order, directivity, h)
    if room.scattering is not None:
        numbers["scattering"] = _compare_scattering(room, args, mics)
    write_json_atomic(out / "crosscheck.json", numbers)
    plot_crosscheck(check, path=out / "crosscheck.png")
    return [out / "crosscheck.json", out / "crosscheck.png"]


def _print_flat_check(check, order) -> None:
    print(f"pyroomacoustics 0.10.1 cross-check (max_order {order}, {check.n_images} images):")
    print(f"  rel L2 per mic      {', '.join(f'{v:.2e}' for v in check.rel_l2)}")
    print(f"  argmax equal        {check.argmax_equal}")
    err = check.inter_mic_delay_error_samples
    if err == err:  # NaN with a single mic: there is no inter-mic delay to compare
        print(f"  inter-mic delay err {err:.2e} samples")
    else:
        print("  inter-mic delay err n/a (needs two or more mics)")
    print(f"  T30 ours / theirs   {check.t30_ours_s:.3f} s / {check.t30_theirs_s:.3f} s "
          f"(target {check.target_rt60_s:.3f} s; theirs off by {100 * check.their_rt60_error:+.1f} %)")


def _build_room(args, absorption):
    """The room the flags describe (calibrated rooms through scenesim.room.calibration.calibrate_room)."""
    from scenesim.room.air import AirAbsorption
    from scenesim.room.bands import OCTAVE_CENTERS_HZ
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.shoebox import ShoeBox

    air = AirAbsorption(temperature_c=args.temperature, humidity_pct=args.humidity) if args.air else None
    dims = tuple(args.dims)
    scat = {} if args.scattering is None else {"scattering": args.scattering}
    if args.band_rt60 is not None:
        return calibrate_room(dims, tuple(args.band_rt60), bands_hz=OCTAVE_CENTERS_HZ, air=air, fs=args.fs, **scat)
    if args.band_absorption is not None:
        values = np.asarray(args.band_absorption, dtype=float)
        if values.size not in (7, 42):
            raise ParameterError("band_absorption", args.band_absorption, "7 or 42 values")
        table = values if values.size == 7 else values.reshape(6, 7)
        return ShoeBox(dims, table, bands_hz=OCTAVE_CENTERS_HZ, air=air, scattering=args.scattering)
    if args.rt60 is not None and args.rt60_method == "calibrated":
        return calibrate_room(dims, args.rt60, air=air, fs=args.fs, **scat)
    return ShoeBox(dims, absorption, rt60_s=args.rt60, rt60_method=args.rt60_method, air=air,
                   scattering=args.scattering)


def _iso3382(room, args, mics, h, directivity) -> dict:
    """ISO 3382-1 parameters of every mic's RIR beside the target's (printed; saved in rir.json)."""
    from benchmarks.cli.rir_iso import iso3382_table
    from scenesim.room.render import room_rir

    # The exact direct path, rendered as h was (same high-pass and directivity), for the exact DRR.
    hd = room_rir(room, args.source, mics, fs=args.fs, max_order=0, length_s=h.shape[1] / args.fs,
                  highpass_hz=args.highpass if args.highpass else None, directivity=directivity)
    return iso3382_table(h, hd, room, args.source, mics, fs=args.fs, rt60_arg=args.rt60)


def _band_meta(room) -> dict:
    meta = {"bands_hz": None if room.bands_hz is None else list(room.bands_hz)}
    if room.target_rt60_s is not None:
        meta["target_rt60_s"] = room.target_rt60_s if np.ndim(room.target_rt60_s) == 0 else list(room.target_rt60_s)
    if room.air is not None:
        meta["air"] = {"temperature_c": room.air.temperature_c, "humidity_pct": room.air.humidity_pct,
                       "pressure_kpa": room.air.pressure_kpa, "standard": "ISO 9613-1"}
    return meta


def _compare_bands(room, args, mics, max_order, out: Path) -> list[Path]:
    """Octave-band materials / air absorption against pyroomacoustics: print and save the figures."""
    from scenesim.room.bands import OCTAVE_CENTERS_HZ, exact_midband_hz
    from scenesim.room.crosscheck_bands import (
        compare_bands_with_pyroomacoustics,
        pyroomacoustics_air_table,
    )

    # pyroomacoustics' ISM is specular: compare our specular part (scattering is not in it).
    check = compare_bands_with_pyroomacoustics(dataclasses.replace(room, scattering=None), args.source, mics,
                                               fs=args.fs, max_order=max_order)
    numbers = check.to_dict()
    what = " + ".join(w for w, on in (("octave-band materials", room.bands_hz is not None),
                                      ("air absorption", room.air is not None)) if on)
    print(f"pyroomacoustics 0.10.1 cross-check, {what} (max_order {max_order}):")
    print(f"  rel L2 per mic      {', '.join(f'{v:.2e}' for v in check.rel_l2)}")
    print("  octave (Hz)         " + " ".join(f"{f:>7g}" for f in check.bands_hz))
    print("  energy ours-theirs  " + " ".join(f"{v:+7.3f}" for v in check.band_energy_db) + " dB")
    print("  T30 ours (s)        " + " ".join(f"{v:7.3f}" for v in check.t30_ours_s))
    print("  T30 theirs (s)      " + " ".join(f"{v:7.3f}" for v in check.t30_theirs_s))
    print(f"  max |T30 diff|      {100 * check.max_t30_rel_diff:.2f} %; max |energy diff| "
          f"{check.max_band_energy_db:.3f} dB")
    if room.air is not None:
        ours = room.air.db_per_m(exact_midband_hz(OCTAVE_CENTERS_HZ)) * 1000.0
        theirs = pyroomacoustics_air_table(room.air.temperature_c, room.air.humidity_pct) * 1000.0
        numbers["air_iso9613_db_per_km"] = [float(v) for v in ours]
        numbers["air_pyroomacoustics_table_db_per_km"] = [float(v) for v in theirs]
        print("  air ISO 9613-1      " + " ".join(f"{v:7.2f}" for v in ours) + " dB/km (used on both sides)")
        print("  air pra table       " + " ".join(f"{v:7.2f}" for v in theirs) + " dB/km (its own coarse class)")
    path = out / "crosscheck.json"
    write_json_atomic(path, numbers)
    return [path]


def _compare_scattering(room, args, mics) -> dict:
    """Per-octave T30, EDT, C50 of mic 0 against pyroomacoustics' ray tracing (same absorption, scattering)."""
    from scenesim.room.crosscheck_scattering import compare_scattering_with_pyroomacoustics

    chk = compare_scattering_with_pyroomacoustics(room, args.source, mics, fs=args.fs)
    print("  scattering vs pyroomacoustics ray tracing (hybrid ISM order 3 + 20000 rays; its scattered "
          "energy is not re-traced, pyroomacoustics issue #415):")
    print("    octave (Hz)      " + " ".join(f"{f:>7g}" for f in chk.bands_hz))
    for label, ours, theirs in (("T30 s", chk.t30_ours_s, chk.t30_theirs_s), ("EDT s", chk.edt_ours_s, chk.edt_theirs_s),
                                ("C50 dB", chk.c50_ours_db, chk.c50_theirs_db)):
        print(f"    {label:<7} ours    " + " ".join(f"{v:7.3f}" for v in ours))
        print(f"    {label:<7} theirs  " + " ".join(f"{v:7.3f}" for v in theirs))
    return chk.to_dict()


def _directivity(args):
    from scenesim.room.directivity import Directivity

    kw = {"azimuth_deg": args.source_azimuth, "elevation_deg": args.source_elevation}
    if args.directivity_p is not None and args.directivity != "cardioid-family":
        raise ParameterError("--directivity-p", args.directivity_p, "only with --directivity cardioid-family "
                                                                  "(it would be ignored)")
    if args.directivity == "cardioid-family":
        with options_named(_OPTIONS):
            return Directivity.cardioid_family(0.5 if args.directivity_p is None else args.directivity_p, **kw)
    if args.directivity == "talker":
        return Directivity.talker(**kw)
    return None


def _compare_directivity(args, room, mics, max_order, directivity) -> list:
    """pyroomacoustics shares the frequency-independent first-order cardioid family: compare
    each distinct band's p (talker: one run per octave) at the same orientation."""
    from scenesim.room.crosscheck_directivity import compare_directivity_with_pyroomacoustics

    coef = directivity.coefficient_array
    rows = []
    print("  directivity vs pyroomacoustics CardioidFamily (same images; tolerance in tests 5e-3):")
    for band, fc in enumerate(directivity.bands_hz):
        p = float(coef[band, 0])  # order 1: p + (1 - p) cos
        chk = compare_directivity_with_pyroomacoustics(
            room, args.source, mics, fs=args.fs, max_order=max_order, p=p,
            azimuth_deg=directivity.azimuth_deg, elevation_deg=directivity.elevation_deg,
        )
        label = f"{fc:g} Hz band" if directivity.n_bands > 1 else "pattern"
        print(f"    {label:>14}: p={p:.3f} rel L2 per mic {', '.join(f'{v:.2e}' for v in chk.rel_l2)} "
              f"(directivity changes the RIR by {max(chk.effect_rel_l2):.2f} rel L2)")
        rows.append({"band_hz": fc, **chk.to_dict()})
    return rows


def _compare_hybrid(args, room, mics, max_order, directivity, h) -> dict:
    """Hybrid vs the full ISM: early taps, T30 and EDT (20 Hz high-passed) of mic 0."""
    from scipy import signal

    from scenesim.room.ism import DEFAULT_MIXING_TIME_S
    from scenesim.room.render import room_rir
    from scenesim.room.rt60 import measure_rt60

    # The same renderer and high-pass as the hybrid RIR, so only the tail differs.
    # Same length as h: the scattered tail's noise (scenesim.room.scattering) depends on the length.
    full = room_rir(
        room, args.source, mics, fs=args.fs, max_order=max_order, length_s=h.shape[1] / args.fs,
        method="fast", directivity=directivity, highpass_hz=args.highpass if args.highpass else None,
    )
    n_mix = round((args.mixing_time or DEFAULT_MIXING_TIME_S) * args.fs)
    sos = signal.butter(2, 20.0, btype="highpass", fs=args.fs, output="sos")
    hf, hh = signal.sosfilt(sos, full[0]), signal.sosfilt(sos, h[0])
    res = {
        "early_max_error_rel_peak": float(np.abs(h[:, :n_mix] - full[:, :n_mix]).max() / np.abs(full).max()),
        "t30_ratio": measure_rt60(hh, args.fs, method="T30") / measure_rt60(hf, args.fs, method="T30"),
        "edt_ratio": measure_rt60(hh, args.fs, method="EDT") / measure_rt60(hf, args.fs, method="EDT"),
    }
    print(f"  hybrid vs full ISM: early taps max err {res['early_max_error_rel_peak']:.1e} of peak, "
          f"T30 ratio {res['t30_ratio']:.3f}, EDT ratio {res['edt_ratio']:.3f}")
    return res
