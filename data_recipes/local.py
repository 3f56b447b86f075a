"""The ``local`` recipe: validate and describe a user's data directory.

Layout (contract.md, "Data directories"): ``speech/`` holds clean speech as WAV/FLAC at
any sampling rate; ``noise/<type>[_<anything>].wav|flac`` holds noise recordings whose
type is the file name before the first underscore.  Every file is read once and
checked: unreadable/corrupt, empty, too short (< :data:`MIN_DURATION_S`) or silent
(RMS below :data:`SILENCE_RMS`) files are reported by name, never silently used.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile as sf

from scenesim.audio import audio_rate, check_rate, resample, write_audio
from scenesim.errors import DataError
from scenesim.validate import check_fs

#: Audio file suffixes recognised in a data directory.
AUDIO_SUFFIXES = (".wav", ".flac")
#: Files shorter than this (s) are rejected.
MIN_DURATION_S = 0.5
#: Files whose RMS (full scale 1.0) is below this (-90 dBFS) are rejected as silent.
SILENCE_RMS = 10.0 ** (-90.0 / 20.0)

# cmu_arctic_us_aew_a0001 / cmu_arctic_awb_a0007 -> talker; cmu_us_slt_arctic/... folder.
_CMU_FILE = re.compile(r"cmu_arctic_(?:[a-z]{2}_)?([a-z]{3})_[ab]\d{4}", re.IGNORECASE)
_CMU_DIR = re.compile(r"cmu_(?:[a-z]{2}_)?([a-z]{3})_arctic", re.IGNORECASE)


@dataclass(frozen=True)
class AudioEntry:
    """One usable audio file of a data directory.

    Attributes
    ----------
    path : Path
    kind : {"speech", "noise"}
    noise_type : str or None
        For noise files: the name part before the first underscore.
    talker : str or None
        For speech files, when the name tells (CMU ARCTIC: ``cmu_arctic_us_aew_a0001`` -> ``aew``).
    duration_s, fs, n_channels : float, int, int
        As stored in the file.
    sha256 : str
        Hex digest of the file's bytes.
    """

    path: Path
    kind: str
    noise_type: str | None
    talker: str | None
    duration_s: float
    fs: int
    n_channels: int
    sha256: str

    def to_dict(self, root: Path) -> dict:
        return {
            "file": self.path.relative_to(root).as_posix(),
            "kind": self.kind,
            "noise_type": self.noise_type,
            "talker": self.talker,
            "duration_s": round(self.duration_s, 6),
            "fs": self.fs,
            "n_channels": self.n_channels,
            "sha256": self.sha256,
        }


@dataclass(frozen=True)
class BadFile:
    """A file that cannot be used, and why (``"unreadable: ..."``, ``"empty"``, ``"too short ..."``, ``"silent ..."``)."""

    path: Path
    reason: str


@dataclass(frozen=True)
class LocalScan:
    """Result of :func:`scan_local`: usable speech and noise files, and the rejected ones."""

    root: Path
    speech: tuple[AudioEntry, ...]
    noise: tuple[AudioEntry, ...]
    bad: tuple[BadFile, ...]

    @property
    def noise_types(self) -> tuple[str, ...]:
        """Sorted distinct noise types present."""
        return tuple(sorted({e.noise_type for e in self.noise}))

    def bad_report(self) -> str:
        """One line per rejected file: ``path: reason``."""
        return "\n".join(f"  {b.path}: {b.reason}" for b in self.bad)

    def manifest(self) -> dict:
        """JSON-ready description: every usable file with talker, duration, fs and sha256."""
        return {
            "recipe": "local",
            "root": str(self.root),
            "speech": [e.to_dict(self.root) for e in self.speech],
            "noise": [e.to_dict(self.root) for e in self.noise],
            "noise_types": list(self.noise_types),
            "bad": [{"file": str(b.path), "reason": b.reason} for b in self.bad],
        }


def talker_from_name(path: Path | str) -> str | None:
    """The talker a file name reveals (CMU ARCTIC conventions), else ``None``."""
    path = Path(path)
    match = _CMU_FILE.search(path.stem)
    if match:
        return match.group(1).lower()
    for parent in path.parents:
        match = _CMU_DIR.search(parent.name)
        if match:
            return match.group(1).lower()
    return None


def noise_type_from_name(path: Path | str) -> str:
    """The noise type of ``noise/<type>[_<anything>].wav``: the stem before the first underscore."""
    return Path(path).stem.split("_", 1)[0].lower()


def sha256_of(path: Path) -> str:
    """Hex SHA-256 of a file, read in 1 MiB chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _audio_files(folder: Path) -> list[Path]:
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in AUDIO_SUFFIXES)


def check_audio_file(path: Path) -> tuple[np.ndarray | None, int, str | None]:
    """Read ``path`` and validate it; return ``(x (n_ch, n), fs, None)`` or ``(None, 0, reason)``."""
    if path.stat().st_size == 0:
        return None, 0, "empty (0 bytes)"
    try:
        check_rate(path, audio_rate(path))  # a 1 Hz or 100 MHz header: refused before its samples are read
    except DataError as exc:
        if "says its sample rate" in str(exc):  # an unreadable header is reported by the read below
            return None, 0, str(exc).replace(f"audio file {path} says its", "header")
    try:
        data, fs = sf.read(str(path), dtype="float64", always_2d=True)
    except Exception as exc:  # soundfile raises several types for corrupt headers/data
        return None, 0, f"unreadable ({type(exc).__name__}: {exc})"
    x = data.T
    if x.shape[1] == 0:
        return None, 0, "empty (no samples)"
    duration = x.shape[1] / fs
    if duration < MIN_DURATION_S:
        return None, 0, f"too short ({duration:.3f} s < {MIN_DURATION_S} s)"
    if not np.all(np.isfinite(x)):
        return None, 0, "contains NaN or Inf samples"
    rms = float(np.sqrt(np.mean(x**2)))
    if rms < SILENCE_RMS:
        return None, 0, f"silent (RMS {20 * np.log10(max(rms, 1e-300)):.1f} dBFS)"
    return x, int(fs), None


def scan_local(root: Path | str, *, hash_files: bool = True) -> LocalScan:
    """Find and validate every audio file under ``root/speech`` and ``root/noise``.

    Parameters
    ----------
    root : path
        The data directory.
    hash_files : bool
        Compute SHA-256 digests (``""`` otherwise).

    Raises
    ------
    DataError
        If ``root`` is not a directory, or has neither ``speech/`` nor ``noise/``.
    """
    root = Path(root).expanduser()
    if not root.is_dir():
        what = "is a file, not a directory" if root.exists() else "does not exist"
        raise DataError(f"data directory {root} {what} (expected speech/ and noise/ inside)")
    if not (root / "speech").is_dir() and not (root / "noise").is_dir():
        raise DataError(
            f"data directory {root} has neither speech/ nor noise/: expected speech/*.wav|flac "
            "and noise/<type>[_<anything>].wav|flac"
        )
    good: dict[str, list[AudioEntry]] = {"speech": [], "noise": []}
    bad: list[BadFile] = []
    for kind in ("speech", "noise"):
        for path in _audio_files(root / kind):
            x, fs, reason = check_audio_file(path)
            if reason is not None:
                bad.append(BadFile(path, reason))
                continue
            good[kind].append(AudioEntry(
                path=path,
                kind=kind,
                noise_type=noise_type_from_name(path) if kind == "noise" else None,
                talker=talker_from_name(path) if kind == "speech" else None,
                duration_s=x.shape[1] / fs,
                fs=fs,
                n_channels=x.shape[0],
                sha256=sha256_of(path) if hash_files else "",
            ))
    return LocalScan(root, tuple(good["speech"]), tuple(good["noise"]), tuple(bad))


def load_mono(path: Path, *, fs: int) -> np.ndarray:
    """Read an audio file as a 1-D float64 array at ``fs``: channels averaged, then resampled.

    Resampling: :func:`scenesim.audio.resample` (polyphase ``resample_poly``, ratio
    reduced by the greatest common divisor).
    """
    fs = check_fs(fs)
    x, fs_file, reason = check_audio_file(Path(path))
    if reason is not None:
        raise DataError(f"{path}: {reason}")
    return resample(x.mean(axis=0), fs_file, fs)


def prepare_local(
    src: Path | str, dest: Path | str | None = None, *, fs: int | None = None, strict: bool = True
) -> dict:
    """Validate ``src``; with ``dest``, copy the usable files there (converted) plus ``manifest.json``.

    Parameters
    ----------
    src : path
        A data directory (``speech/``, ``noise/``).
    dest : path, optional
        Where to write a converted copy: mono 16-bit WAV at ``fs`` (or the file's own
        rate) under ``dest/speech`` and ``dest/noise``, and ``dest/manifest.json``
        describing the written files.  Without it nothing is written.
    fs : int, optional
        Target sampling rate of the converted copy.
    strict : bool
        Raise :class:`DataError` listing every bad file (default); otherwise list them
        in the manifest's ``"bad"`` and continue.

    Returns
    -------
    dict
        The manifest (of ``dest`` when given, else of ``src``).
    """
    scan = scan_local(src)
    if scan.bad and strict:
        raise DataError(f"{len(scan.bad)} unusable file(s) in {scan.root}:\n{scan.bad_report()}")
    if not scan.speech and not scan.noise:
        raise DataError(f"no usable speech or noise files in {scan.root}")
    if dest is None:
        return scan.manifest()
    dest = Path(dest).expanduser()
    for entry in scan.speech + scan.noise:
        rel = entry.path.relative_to(scan.root)
        out = (dest / rel).with_suffix(".wav")
        out.parent.mkdir(parents=True, exist_ok=True)
        rate = entry.fs if fs is None else check_fs(fs)
        # Resampling can overshoot a full-scale file: normalize keeps it representable.
        write_audio(out, load_mono(entry.path, fs=rate), rate, subtype="PCM_16", normalize=True)
    manifest = scan_local(dest).manifest()
    manifest["recipe"] = "local"
    manifest["converted_from"] = str(scan.root)
    manifest["bad"] = [{"file": str(b.path), "reason": b.reason} for b in scan.bad]
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest
