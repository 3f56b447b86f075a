"""``scenesim enhance IN.wav OUT.wav --enhancer NAME [--param k=v ...]``: run one enhancer on a file.

The input is the user's own recording, ``(n_channels, n_samples)`` with channel 0 the
front/reference mic; its header's sample rate is held to the range of ``--fs`` before any
work.  A 1-channel enhancer given a multichannel file gets channel 0 (the same convention as
a sweep) and says so.  The output is written as a float WAV at the input's rate, the same
length as the input and **latency compensated**: the enhancer runs on the input followed by
``L`` samples of silence (``L`` its declared latency) and the first ``L`` output samples are
dropped, so ``out[n]`` is the response to ``in[n]`` and the tail holds the response to the
input's end (for a causal enhancer the kept samples equal the uncompensated output shifted
by ``L``).  ``--keep-latency`` writes today's delayed output instead.  The output's
``comment`` field records the enhancer, its parameters, the latency and the delay the file
still holds (:func:`benchmarks.metrics.align.enhance_comment`), which ``scenesim score``
reads to align the file with its reference.

Stage parameters of a chain use dotted names: ``--param ss.alpha=0.9``.  ``--channels``
picks channels of a multichannel recording (reference mic first) and ``--fs`` resamples
the input first (for enhancers with ``supported_fs``).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

import scenesim
from benchmarks.cli.checks import check_cli_fs, check_input_file, check_out_file, options_named
from benchmarks.metrics.align import enhance_comment
from enhancers.core.registry import get, make, with_geometry
from scenesim.audio import check_audio_rate, read_audio, write_audio
from scenesim.errors import DataError, ParameterError
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS
from scenesim.validate import check_physical


def add_parser(subparsers):
    p = subparsers.add_parser(
        "enhance",
        help="run an enhancer on your own recording",
        description=(
            "Run one registered enhancer on your own recording (channel 0 = front/reference "
            "mic). A 1-channel enhancer given a multichannel file gets channel 0. The output "
            "is a float WAV at the input's rate and length with the enhancer's latency removed "
            "(--keep-latency keeps it); the enhancer, its parameters and the latency are recorded "
            "in the file's comment field for scenesim score. Chain stages take dotted "
            "parameters: --param ss.alpha=0.9."
        ),
    )
    p.add_argument("input", type=Path, metavar="IN", help="input audio (channel 0 = front/reference mic)")
    p.add_argument("output", metavar="OUT", help="output WAV (float samples)")
    p.add_argument("--enhancer", "-e", required=True, help="registry name, e.g. eb, ss, eb-ss, das, eb@1")
    p.add_argument(
        "--param", "-p", action="append", default=[], metavar="K=V",
        help="enhancer parameter (repeatable); chain stages as stage.param=value",
    )
    p.add_argument("--spacing-m", type=float, default=None, help="mic spacing in metres (enhancers that need geometry)")
    p.add_argument("--c-mps", type=float, default=None, help="speed of sound in m/s (default 343)")
    p.add_argument(
        "--channels", default=None, metavar="I,J",
        help="comma-separated input channels to use, reference mic first (default: all)",
    )
    p.add_argument("--fs", type=int, default=None, help="resample the input to this rate (Hz) first")
    p.add_argument("--trace", type=Path, default=None, metavar="NPZ", help="also save the enhancer's trace (beta, gains, ...) to this .npz")
    p.add_argument("--keep-latency", action="store_true",
                   help="write the output delayed by the enhancer's latency (default: latency removed)")
    p.set_defaults(func=run)
    return p


def _parse_params(items: list[str]) -> dict[str, str]:
    values: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ParameterError("--param", item, "KEY=VALUE")
        values[key.strip()] = value.strip()
    return values


def _parse_channels(text: str, n_available: int, path) -> list[int]:
    try:
        picks = [int(part) for part in text.split(",")]
    except ValueError:
        raise ParameterError("--channels", text, "comma-separated channel indices such as 0,1") from None
    if len(set(picks)) != len(picks):  # one mic fed twice is no pair
        raise ParameterError("--channels", text, "distinct channel indices such as 0,1")
    bad = [i for i in picks if not 0 <= i < n_available]
    if not picks or bad:
        raise ParameterError(
            "--channels", text,
            f"indices in 0..{n_available - 1} ({path} has {n_available} channel(s); e.g. --channels "
            f"{','.join(str(i) for i in range(min(2, n_available)))})",
        )
    return picks


def _suggest_channels(n_in: int) -> str:
    return ",".join(str(i) for i in range(n_in))


def _output_subtype(path: Path) -> str:
    """The sample format OUT is written in: float where the container has it (WAV), else 24- or
    16-bit PCM (FLAC); a container with neither (OGG, MP3: lossy) is refused before the work."""
    import soundfile as sf

    fmt = path.suffix[1:].upper()
    if fmt in sf.available_formats():
        for subtype in ("FLOAT", "PCM_24", "PCM_16"):
            if sf.check_format(fmt, subtype):
                return subtype
    raise ParameterError("OUT", str(path), "a file name ending in .wav or .flac (lossless; .ogg/.mp3 are not written)")


def _check_options(args) -> str:
    """Every option checked before any work; returns OUT's sample format."""
    check_input_file("IN", args.input)
    check_audio_rate(args.input)
    args.output = check_out_file("OUT", args.output)
    if args.output.resolve() == args.input.resolve():
        raise ParameterError("OUT", str(args.output), "a file other than IN (it would overwrite the recording)")
    subtype = _output_subtype(args.output)
    if args.trace is not None:
        args.trace = check_out_file("--trace", args.trace)
        for role, path in (("IN", args.input), ("OUT", args.output)):
            if args.trace.resolve() == Path(path).resolve():
                raise ParameterError("--trace", str(args.trace), f"a file other than {role} (it would be overwritten)")
    check_cli_fs("--fs", args.fs)
    if args.c_mps is not None:
        check_physical("--c-mps", args.c_mps, "c_mps")
    if args.spacing_m is not None:
        check_physical("--spacing-m", args.spacing_m, "spacing_m")
    return subtype


def run(args) -> int:
    subtype = _check_options(args)
    cls = get(args.enhancer)  # unknown names raise with "Did you mean ...?"
    typed = _parse_params(args.param)
    with options_named({key: f"--param {key}" for key in typed}):
        enhancer = make(args.enhancer, **cls.Params.coerce_strings(typed))
    tags = enhancer.tags
    notes = []
    if args.spacing_m is not None or args.c_mps is not None:
        if tags.needs_geometry:
            p = enhancer.params
            with options_named({"spacing_m": "--spacing-m", "c_mps": "--c-mps"}):
                enhancer = with_geometry(
                    enhancer,
                    spacing_m=p.spacing_m if args.spacing_m is None else args.spacing_m,
                    c_mps=(p.c_mps or SPEED_OF_SOUND_MPS) if args.c_mps is None else args.c_mps,
                )
        else:
            notes.append(f"{enhancer.name} needs no geometry: --spacing-m/--c-mps ignored")
    elif tags.needs_geometry:
        notes.append(f"using the default spacing_m={enhancer.params.spacing_m} m (set --spacing-m)")

    x, fs = read_audio(args.input, fs=args.fs)
    if args.channels is not None:
        x = x[_parse_channels(args.channels, x.shape[0], args.input)]
    n_in = tags.channels_in
    if x.shape[0] != n_in:
        if n_in == 1:
            notes.append(f"{enhancer.name} takes 1 channel: using channel 0 (reference mic) of {x.shape[0]}")
            x = x[0:1]
        else:
            way_out = (f"; pick {n_in} with --channels {_suggest_channels(n_in)}" if x.shape[0] > n_in
                       else f"; record with {n_in} mics or choose a 1-channel enhancer such as ss")
            raise DataError(
                f"{args.input} has {x.shape[0]} channel(s) but enhancer {enhancer.name!r} expects "
                f"{n_in} (channel 0 = front/reference mic){way_out}"
            )
    if x.shape[1] <= tags.latency_samples:
        warnings.warn(
            f"{args.input} has {x.shape[1]} samples, no more than {enhancer.name}'s latency of "
            f"{tags.latency_samples} samples: the output holds almost nothing of the input",
            stacklevel=1,
        )

    latency = tags.latency_samples
    output, trace = process_compensated(enhancer, x, fs, keep_latency=args.keep_latency)
    if subtype != "FLOAT":
        peak = float(np.max(np.abs(output)))
        scaled = f"; scaled from peak {peak:.3g} to 0.99" if peak > 1 else ""
        notes.append(f"{args.output.suffix} holds no float samples: written as {subtype}{scaled}")
    comment = enhance_comment(enhancer=f"{enhancer.name}@{enhancer.version}", params=enhancer.params.to_dict(),
                              latency_samples=latency, removed=not args.keep_latency, fs=fs,
                              scenesim_version=scenesim.__version__)
    write_audio(args.output, output, fs, subtype=subtype, normalize=True, comment=comment)
    if args.trace is not None:
        np.savez(args.trace, **{k.replace(".", "__"): v for k, v in trace.items()})

    for note in notes:
        print(f"scenesim enhance: note: {note}", file=sys.stderr)
    print(
        f"{enhancer.name}@{enhancer.version}: {args.input} ({x.shape[0]} ch, {x.shape[1]} samples, "
        f"{fs} Hz) -> {args.output} ({output.shape[0]} ch)"
    )
    state = "kept in the output (--keep-latency)" if args.keep_latency else "removed from the output"
    print(f"latency: {latency} samples ({1000.0 * latency / fs:.3f} ms), {state}")
    return 0


def process_compensated(enhancer, x: np.ndarray, fs: int, *, keep_latency: bool = False):
    """``(output (n_out, n), trace)`` of ``enhancer`` on ``x`` ``(n_ch, n)`` with its latency removed.

    The input is followed by ``L = tags.latency_samples`` zeros and the output's first ``L``
    samples are dropped: ``out[:, k] = y[:, k + L]`` where ``y`` is the output on the padded
    input.  ``keep_latency=True``: the output on ``x`` as it is (delayed by ``L``).
    """
    latency = enhancer.tags.latency_samples
    if keep_latency or latency == 0:
        result = enhancer.process(x, fs)
        return result.output, result.trace
    padded = np.concatenate([x, np.zeros((x.shape[0], latency))], axis=1)
    result = enhancer.process(padded, fs)
    return result.output[:, latency:latency + x.shape[1]], result.trace
