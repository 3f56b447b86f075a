"""The ``noisex92`` recipe: convert a user's NOISEX-92 files into the data-directory layout.

NOISEX-92 (Varga & Steeneken 1993) has no stable official download, so the user points
at a folder holding its files (``babble.wav``, ``factory1.wav``, ... as commonly
distributed: about 235 s each at 19.98 kHz; ``.wav``, ``.flac`` or the original
``.mat`` with one variable named like the file).  Each file found is averaged to mono,
resampled to ``fs`` and written as ``<dest>/noise/<type>_noisex92[-2].wav`` (type =
the name without its take number: ``factory1`` -> ``factory``, ``factory2`` ->
``factory_noisex92-2.wav``), with ``manifest.json``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from data_recipes.local import check_audio_file, sha256_of
from scenesim.audio import resample, write_audio
from scenesim.errors import DataError
from scenesim.validate import check_fs, check_positive

#: NOISEX-92 file stem -> noise type in the data directory.
NOISEX_FILES = {
    "babble": "babble", "buccaneer1": "buccaneer", "buccaneer2": "buccaneer",
    "destroyerengine": "destroyerengine", "destroyerops": "destroyerops", "f16": "f16",
    "factory1": "factory", "factory2": "factory", "hfchannel": "hfchannel", "leopard": "leopard",
    "m109": "m109", "machinegun": "machinegun", "pink": "pink", "volvo": "volvo", "white": "white",
}
#: Sampling rate of the original NOISEX-92 recordings (Hz), used for ``.mat`` files.
NOISEX_FS = 19980
#: Files shorter than this (s) are rejected: the originals last about 235 s.
MIN_DURATION_S = 60.0


def prepare_noisex92(
    src: Path | str,
    dest: Path | str,
    *,
    fs: int = 16000,
    min_duration_s: float = MIN_DURATION_S,
) -> dict:
    """Convert the NOISEX-92 files found in ``src`` into ``dest/noise``; return the manifest.

    Raises
    ------
    DataError
        If ``src`` holds none of the expected files, or any found file is unreadable,
        silent or shorter than ``min_duration_s`` (all such files are listed).
    """
    fs = check_fs(fs)
    min_duration_s = check_positive("min_duration_s", min_duration_s)
    src = Path(src).expanduser()
    if not src.is_dir():
        raise DataError(f"NOISEX-92 folder {src} {'is a file, not a folder' if src.exists() else 'does not exist'}")
    found = {}
    for path in sorted(src.iterdir()):
        stem = path.stem.lower()
        if stem in NOISEX_FILES and path.suffix.lower() in (".wav", ".flac", ".mat"):
            found.setdefault(stem, path)
    if not found:
        raise DataError(
            f"no NOISEX-92 files in {src}: expected some of "
            + ", ".join(f"{s}.wav" for s in NOISEX_FILES)
        )
    problems, converted = [], []
    for stem, path in found.items():
        x, rate, reason = _read(path)
        if reason is None and x.shape[1] / rate < min_duration_s:
            reason = f"too short ({x.shape[1] / rate:.1f} s < {min_duration_s:g} s)"
        if reason is not None:
            problems.append(f"  {path}: {reason}")
            continue
        converted.append((stem, resample(x.mean(axis=0), rate, fs)))
    if problems:
        raise DataError("unusable NOISEX-92 file(s):\n" + "\n".join(problems))
    dest = Path(dest).expanduser()
    (dest / "noise").mkdir(parents=True, exist_ok=True)
    entries = []
    for stem, y in converted:
        kind = NOISEX_FILES[stem]
        take = stem[-1] if stem[-1].isdigit() and stem[-1] != "1" else ""
        rel = f"noise/{kind}_noisex92{'-' + take if take else ''}.wav"
        write_audio(dest / rel, y, fs, subtype="PCM_16", normalize=True)
        entries.append({"file": rel, "noise_type": kind, "original": str(found[stem]),
                        "duration_s": round(y.size / fs, 6), "fs": fs, "sha256": sha256_of(dest / rel)})
    manifest = {"recipe": "noisex92", "source": str(src), "dest": str(dest), "files": entries,
                "missing": sorted(set(NOISEX_FILES) - set(found))}
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest


def _read(path: Path) -> tuple[np.ndarray | None, int, str | None]:
    """Like :func:`check_audio_file`, also for NOISEX ``.mat`` files (one array, 19.98 kHz)."""
    if path.suffix.lower() != ".mat":
        return check_audio_file(path)
    from scipy.io import loadmat

    try:
        data = loadmat(str(path))
    except Exception as exc:  # scipy raises several types for corrupt .mat files
        return None, 0, f"unreadable ({type(exc).__name__}: {exc})"
    arrays = [v for k, v in data.items() if not k.startswith("__") and isinstance(v, np.ndarray)]
    if not arrays or arrays[0].size == 0:
        return None, 0, "no audio array in the .mat file"
    x = np.asarray(arrays[0], dtype=float).reshape(1, -1)
    x = x / max(np.max(np.abs(x)), 1e-12)  # the .mat files store 16-bit integer values
    return x, NOISEX_FS, None
