"""``scenesim simulate``: render one scene to WAV files (mixture, speech image, noise image, reference).

Writes into ``--out DIR``: ``mixture.wav`` (2 ch), ``speech_image.wav`` (2 ch),
``noise_image.wav`` (2 ch), ``reference.wav`` (1 ch), all 32-bit float, and ``scene.json``
(every scene parameter, the scene key, the noise gain and where the signals came from).
With a sensor model (``--mic-gain-db``, ``--mic-phase-deg``, ``--mic-highpass-hz``,
``--self-noise-dba``, ``--speech-spl-db``) every per-mic image is what the mics output, and
``self_noise.wav`` (2 ch) holds the self-noise on its own (it is also in the noise image).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import signal as sps

from benchmarks.cli.checks import (
    check_cli_fs,
    check_input_file,
    check_snr_db,
    prepare_out_dir,
)
from scenesim.audio import read_audio, write_audio
from scenesim.errors import ParameterError
from scenesim.files import write_json_atomic
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import (
    NOISE_FIELDS,
    REFERENCES,
    SNR_MODES,
    NoiseSource,
    Scene,
    SourcePlacement,
    render_images,
)
from scenesim.scene.geometry import MicPair
from scenesim.scene.sensors import SensorModel
from scenesim.validate import check_outside_pair, check_physical, check_seed, check_snr_band

DEFAULT_DURATION_S = 3.0

HELP = """\
Render one acoustic scene at a two-mic pair to WAV files.

Without --speech, a built-in deterministic test signal is used: seeded Gaussian noise
with a speech-like spectral tilt (band 100 Hz - 4 kHz, -6 dB/octave above 500 Hz),
modulated at a 4 Hz syllable rate and gated into 'words' and pauses.  It is NOT speech
(use --speech for real speech, or the data recipes for an artificial voice).  Without
--noise, white or pink Gaussian noise is generated from --seed.  Free field unless
--room and --rt60 are given."""


def add_parser(subparsers):
    p = subparsers.add_parser(
        "simulate",
        help="render one scene to WAV files (mixture, speech image, noise image, reference)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    _add_signal_args(p)
    _add_geometry_args(p)
    _add_sensor_args(p)
    p.add_argument("--fs", type=int, default=16000, help="sampling rate in Hz (default 16000)")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.set_defaults(func=run)


def _add_signal_args(p) -> None:
    """Speech and noise sources, length, SNR and how it is measured."""
    p.add_argument("--speech", type=Path, metavar="FILE", help="clean speech file (channel 0 is used)")
    noise = p.add_mutually_exclusive_group()
    noise.add_argument("--noise", type=Path, metavar="FILE", help="noise file (mono, or 2 ch for diffuse/incoherent)")
    noise.add_argument("--noise-type", choices=("white", "pink"), default="white", help="generated noise (default white)")
    p.add_argument("--duration-s", type=float, metavar="S",
                   help=f"length in seconds (default: the speech file, or {DEFAULT_DURATION_S:g} s)")
    p.add_argument("--snr-db", type=float, default=0.0, help="SNR at the reference mic in dB (default 0)")
    p.add_argument("--snr-mode", choices=SNR_MODES, default="total", help="speech power: whole signal or active level")
    p.add_argument("--snr-band-hz", type=float, nargs=2, metavar=("LO", "HI"),
                   help="set the SNR in this band (default: full band)")
    p.add_argument("--field", choices=NOISE_FIELDS, default="point", help="noise field (default point)")
    p.add_argument("--wind-speed-mps", type=float, default=5.0, metavar="M/S", help="wind speed of --field wind")


def _add_geometry_args(p) -> None:
    """Where the sources and the pair are: free field or a shoebox room."""
    p.add_argument("--speech-az", type=float, default=45.0, metavar="DEG", help="speech azimuth (default 45)")
    p.add_argument("--noise-az", type=float, default=270.0, metavar="DEG", help="noise azimuth (default 270)")
    p.add_argument("--distance-m", type=float, default=1.0, help="source distance from the pair centre (default 1.0)")
    p.add_argument("--near-field", action="store_true", help="free field: point sources instead of plane waves")
    p.add_argument("--rt60", type=float, metavar="S", help="reverberation time of the room (needs --room)")
    p.add_argument("--room", type=float, nargs=3, metavar=("LX", "LY", "LZ"),
                   help="shoebox dimensions in metres (needs --rt60)")
    p.add_argument("--pair-center", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="pair centre in metres (default: room centre, or the origin)")
    p.add_argument("--reference", choices=REFERENCES, default="direct", help="reference signal in a room (default direct)")
    p.add_argument("--spacing-m", type=float, default=0.0214, help="mic spacing in metres (default 0.0214)")


def _add_sensor_args(p) -> None:
    """The sensor model (scenesim.scene.sensors); default: ideal identical noiseless mics."""
    p.add_argument("--sensor-noise-db", type=float, help="sensor self-noise relative to the speech power (dB)")
    sensors = p.add_argument_group("sensors (scenesim.scene.sensors; default: ideal identical noiseless mics)")
    sensors.add_argument("--mic-gain-db", type=float, default=0.0, metavar="DB", help="rear mic sensitivity re front")
    sensors.add_argument("--mic-phase-deg", type=float, default=0.0, metavar="DEG", help="rear mic phase re front")
    sensors.add_argument("--mic-highpass-hz", type=float, nargs="+", metavar="HZ",
                         help="first-order high-pass corner for both mics, or FRONT REAR")
    sensors.add_argument("--self-noise-dba", type=float, metavar="DBA", help="mic self-noise in dBA SPL (e.g. 30)")
    sensors.add_argument("--speech-spl-db", type=float, default=65.0, metavar="DB",
                         help="talker level at the reference mic (default 65)")


def builtin_test_signal(n: int, fs: int, rng: np.random.Generator) -> np.ndarray:
    """Speech-shaped, syllable-modulated, gated Gaussian noise ``(n,)`` with peak 0.5 (not speech)."""
    x = rng.standard_normal(n)
    x = sps.sosfilt(
        sps.butter(2, [100.0, min(4000.0, 0.45 * fs)], btype="bandpass", fs=fs, output="sos"), x
    )
    x = sps.lfilter([1.0 - np.exp(-2 * np.pi * 500 / fs)], [1.0, -np.exp(-2 * np.pi * 500 / fs)], x)
    t = np.arange(n) / fs
    syllables = 0.5 * (1.0 - np.cos(2 * np.pi * 4.0 * t))
    # Words of 0.3-0.9 s separated by 0.1-0.4 s pauses.
    gate = np.zeros(n)
    pos = int(0.1 * fs)
    while pos < n:
        length = int(rng.uniform(0.3, 0.9) * fs)
        gate[pos : pos + length] = 1.0
        pos += length + int(rng.uniform(0.1, 0.4) * fs)
    gate = sps.lfilter([0.01], [1.0, -0.99], gate)  # soft edges (~6 ms)
    y = x * syllables * gate
    peak = np.max(np.abs(y))
    return 0.5 * y / peak if peak > 0 else y


def generated_noise(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """White or pink (1/f power) Gaussian noise ``(n,)`` of unit variance."""
    x = rng.standard_normal(n)
    if kind == "pink":
        spec = np.fft.rfft(x)
        f = np.arange(spec.size, dtype=float)
        spec[1:] /= np.sqrt(f[1:])
        spec[0] = 0.0
        x = np.fft.irfft(spec, n=n)
    return x / max(float(np.std(x)), 1e-300)


# Scene/room parameter names -> the options that set them, so an error names what was typed.
_OPTION_OF = {
    "distance_m": "--distance-m",
    "spacing_m": "--spacing-m",
    "center_m": "--pair-center",
    "dims_m": "--room",
    "rt60_s": "--rt60",
    "sensor_noise_db": "--sensor-noise-db",
    "seed": "--seed",
    "wind_speed_mps": "--wind-speed-mps",
    "snr_band_hz": "--snr-band-hz",
    "snr_db": "--snr-db",
    "snr_mode": "--snr-mode",
    "fs": "--fs",
}


def build_sensors(args) -> SensorModel | None:
    """The sensor model of the command line, or None for ideal sensors."""
    hp = args.mic_highpass_hz
    if hp is not None and len(hp) not in (1, 2):
        raise ParameterError("--mic-highpass-hz", hp, "one corner in Hz, or FRONT REAR")
    flags = {"gain_db": "--mic-gain-db", "phase_deg": "--mic-phase-deg", "highpass_hz": "--mic-highpass-hz",
             "mic_highpass_hz": "--mic-highpass-hz", "self_noise_dba": "--self-noise-dba",
             "speech_spl_db": "--speech-spl-db"}  # fmt: skip
    try:
        model = SensorModel.from_mismatch(
            gain_db=args.mic_gain_db,
            phase_deg=args.mic_phase_deg,
            highpass_hz=None if hp is None else (hp[0] if len(hp) == 1 else tuple(hp)),
            self_noise_dba=args.self_noise_dba,
            speech_spl_db=args.speech_spl_db,
        )
    except ParameterError as exc:  # name the flag the user typed, not the library's keyword
        raise ParameterError(flags.get(exc.name, exc.name), exc.value, exc.allowed) from None
    return None if model.ideal else model


def build_scene(args) -> Scene:
    """The :class:`Scene` described by the command-line arguments (errors name the options)."""
    try:
        return _build_scene(args)
    except ParameterError as exc:
        if exc.name.endswith("position_m"):  # a source placed outside the room / on a mic
            which, az = ("speech", args.speech_az) if exc.name.startswith("speech") else ("noise", args.noise_az)
            try:
                where = "; the {} source would be at ({})".format(
                    which, ", ".join(f"{float(v):.3f}" for v in exc.value))
            except (TypeError, ValueError):  # no position to show
                where = ""
            raise ParameterError(
                "--distance-m", args.distance_m,
                f"a distance (with --{which}-az {az:g}) giving {exc.allowed}{where}",
            ) from None
        option = _OPTION_OF.get(exc.name.rsplit(".", 1)[-1])
        if option is None:
            raise
        raise ParameterError(option, exc.value, exc.allowed) from None


def _build_scene(args) -> Scene:
    room = None
    if (args.rt60 is None) != (args.room is None):
        raise ParameterError(
            "--rt60/--room", (args.rt60, args.room), "both --rt60 and --room, or neither"
        )
    if args.room is not None:
        room = ShoeBox(tuple(args.room), rt60_s=args.rt60)
        center = tuple(args.pair_center) if args.pair_center else tuple(0.5 * v for v in args.room)
    else:
        center = tuple(args.pair_center) if args.pair_center else (0.0, 0.0, 0.0)
    return Scene(
        fs=args.fs,
        pair=MicPair(center_m=center, spacing_m=args.spacing_m),
        room=room,
        speech=SourcePlacement(azimuth_deg=args.speech_az, distance_m=args.distance_m),
        noises=(
            NoiseSource(
                field=args.field,
                azimuth_deg=args.noise_az,
                distance_m=args.distance_m,
                wind_speed_mps=args.wind_speed_mps,
            ),
        ),
        snr_db=args.snr_db,
        far_field=not args.near_field,
        snr_mode=args.snr_mode,
        reference=args.reference,
        sensor_noise_db=args.sensor_noise_db,
        seed=args.seed,
        sensors=build_sensors(args),
        snr_band_hz=None if args.snr_band_hz is None else tuple(args.snr_band_hz),
    )


#: Options checked against scenesim.validate.PHYSICAL_RANGES (the table sweep files use too).
_PHYSICAL_OPTIONS = (("--speech-az", "speech_az", "azimuth_deg"), ("--noise-az", "noise_az", "azimuth_deg"),
                     ("--distance-m", "distance_m", "distance_m"), ("--spacing-m", "spacing_m", "spacing_m"),
                     ("--duration-s", "duration_s", "duration_s"), ("--rt60", "rt60", "rt60_s"))


def check_physical_options(args) -> None:
    """Every typed value within its physical range, before any work (errors name the option)."""
    check_cli_fs("--fs", args.fs)
    check_snr_db("--snr-db", args.snr_db)
    check_seed("--seed", args.seed)
    for option, attr, quantity in _PHYSICAL_OPTIONS:
        if getattr(args, attr) is not None:
            check_physical(option, getattr(args, attr), quantity)
    for value in args.room or ():
        check_physical("--room", value, "room_dim_m")
    for value in args.mic_highpass_hz or ():
        check_physical("--mic-highpass-hz", value, "highpass_hz")
    check_outside_pair("--distance-m", args.distance_m, args.spacing_m)
    if args.snr_band_hz is not None:
        check_snr_band("--snr-band-hz", tuple(args.snr_band_hz), args.fs)


#: Files simulate writes into --out (self_noise.wav only with --self-noise-dba).
OUTPUT_NAMES = ("mixture.wav", "speech_image.wav", "noise_image.wav", "reference.wav", "self_noise.wav",
                "scene.json")


def _check_not_overwritten(option: str, path, out) -> None:
    """An input inside --out under a name simulate writes would be overwritten mid-run: refuse it."""
    if Path(path).resolve() in {(Path(out) / name).resolve() for name in OUTPUT_NAMES}:
        raise ParameterError(option, str(path), f"a file that --out {out} does not overwrite "
                             f"(simulate writes {', '.join(OUTPUT_NAMES)} there): choose another --out")


def run(args) -> int:
    check_physical_options(args)
    scene = build_scene(args)
    fs = scene.fs
    for option, path in (("--speech", args.speech), ("--noise", args.noise)):
        if path is not None:
            check_input_file(option, path)
            _check_not_overwritten(option, path, args.out)
    out: Path = prepare_out_dir("--out", args.out)
    rng = np.random.default_rng([scene.seed, 1000])  # streams apart from the scene's own
    if args.speech is not None:
        x, _ = read_audio(args.speech, fs=fs)
        speech = x[0]
        if args.duration_s is not None:
            speech = speech[: int(round(args.duration_s * fs))]
        speech_source = str(args.speech)
    else:
        n = int(round((args.duration_s or DEFAULT_DURATION_S) * fs))
        speech = builtin_test_signal(n, fs, rng)
        speech_source = f"builtin:speech-shaped-modulated-noise(seed={scene.seed})"
    n = speech.size
    if args.noise is not None:
        y, _ = read_audio(args.noise, fs=fs)
        noise = y[0] if (args.field in ("point", "spread") or y.shape[0] != 2) else y
        noise_source = str(args.noise)
    else:
        # Twice the length, so a diffuse field gets two disjoint halves as independent channels.
        noise = generated_noise(args.noise_type, 2 * n, rng)
        noise_source = f"generated:{args.noise_type}(seed={scene.seed})"
    rendered = render_images(scene, speech, [noise]).mix()

    files = {
        "mixture": rendered.mixture,
        "speech_image": rendered.speech_image,
        "noise_image": rendered.noise_image,
        "reference": rendered.reference,
    }
    if scene.sensors is not None and scene.sensors.self_noise_dba is not None:
        files["self_noise"] = rendered.self_noise_image
    for name, sig in files.items():
        write_audio(out / f"{name}.wav", sig, fs, subtype="FLOAT")
    write_json_atomic(
        out / "scene.json",
        {
            "scene": scene.to_dict(),
            "key": scene.key(),
            "fs": fs,
            "n_samples": int(n),
            "snr_db": rendered.snr_db,
            "noise_gain": rendered.noise_gain,
            "sensors": (scene.sensors.describe() if scene.sensors is not None else None),
            "speech_source": speech_source,
            "noise_source": noise_source,
            "files": {name: f"{name}.wav" for name in files},
        },
    )
    print(
        f"scenesim simulate: wrote {len(files)} WAV files and scene.json to {out} (key {scene.key()[:12]})"
    )
    return 0
