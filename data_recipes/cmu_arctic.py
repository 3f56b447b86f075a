"""The ``cmu-arctic`` recipe: download a subset of CMU ARCTIC into a data directory.

CMU ARCTIC (Kominek & Black 2003, "free for use for any purpose") is served by
festvox.org one file per utterance::

    http://festvox.org/cmu_arctic/cmu_arctic/cmu_us_<voice>_arctic/wav/arctic_<id>.wav

(16 kHz mono 16-bit WAV; ``packed/cmu_us_<voice>_arctic.tar.bz2`` holds whole voices).
Files land in ``<dest>/speech/cmu_arctic_us_<voice>_<id>.wav`` (a data directory,
talker parsed back by :func:`data_recipes.local.talker_from_name`), and
``<dest>/manifest.json`` records URL, size and SHA-256 of each.  Already complete
files whose SHA-256 matches the manifest are not fetched again; a ``.part`` left by an
interrupted transfer is resumed.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Sequence
from pathlib import Path

from data_recipes.download import DEFAULT_TIMEOUT_S, DownloadError, cache_dir, fetch
from data_recipes.local import sha256_of
from scenesim.errors import DataError, ParameterError
from scenesim.validate import check_positive

#: Root of the per-utterance WAV files on the official site.
BASE_URL = "http://festvox.org/cmu_arctic/cmu_arctic/"
#: The voices of CMU ARCTIC.
VOICES = ("aew", "ahw", "aup", "awb", "axb", "bdl", "clb", "eey", "fem", "gka", "jmk", "ksp",
          "ljm", "lnh", "rms", "rxr", "slp", "slt")
#: Default subset: two male (bdl, rms) and two female (slt, clb) US talkers.
DEFAULT_TALKERS = ("bdl", "slt", "rms", "clb")
#: Default utterances per talker.
DEFAULT_UTTERANCES = tuple(f"a{i:04d}" for i in range(1, 6))

_UTTERANCE = re.compile(r"^[ab]\d{4}$")

OFFLINE_HINT = (
    "To work offline, supply speech from a local folder instead: put WAV/FLAC files in "
    "DIR/speech/ (and noise recordings as DIR/noise/<type>_<anything>.wav) and pass "
    "--data-dir DIR or set SCENESIM_DATA=DIR (check it with `scenesim data prepare local --src DIR`); "
    "without any data directory the built-in artificial voice is used."
)


def prepare_cmu_arctic(
    dest: Path | str | None = None,
    *,
    talkers: Sequence[str] = DEFAULT_TALKERS,
    utterances: Sequence[str] = DEFAULT_UTTERANCES,
    base_url: str = BASE_URL,
    timeout_s: float = DEFAULT_TIMEOUT_S,
) -> dict:
    """Download ``talkers`` x ``utterances`` of CMU ARCTIC into the data directory ``dest``.

    Parameters
    ----------
    dest : path, optional
        Data directory to fill; default ``$SCENESIM_CACHE/cmu_arctic`` or
        ``~/.cache/scenesim/cmu_arctic``.
    talkers : sequence of str
        Voice codes from :data:`VOICES`.
    utterances : sequence of str
        Utterance ids like ``"a0001"`` / ``"b0539"``.
    base_url : str
        Root URL (tests point it at a closed local port).
    timeout_s : float
        Connect/read timeout per request (s); there are no retries.

    Returns
    -------
    dict
        The manifest also written to ``dest/manifest.json``.

    Raises
    ------
    DataError
        When the site cannot be reached: raised at the first failure, naming the local
        folder alternative; directories this call created are removed if left empty.
    """
    talkers = tuple(talkers)
    utterances = tuple(utterances)
    for talker in talkers:
        if talker not in VOICES:
            raise ParameterError("talkers", talker, "CMU ARCTIC voices: " + ", ".join(VOICES))
    for utt in utterances:
        if not isinstance(utt, str) or not _UTTERANCE.match(utt):
            raise ParameterError("utterances", utt, "ids like 'a0001' or 'b0123'")
    if not talkers or not utterances:
        raise ParameterError("talkers", talkers, "at least one talker and one utterance")
    timeout_s = check_positive("timeout_s", timeout_s)
    dest = Path(dest).expanduser() if dest is not None else cache_dir() / "cmu_arctic"
    base_url = base_url if base_url.endswith("/") else base_url + "/"

    created = [p for p in (dest, dest / "speech") if not p.exists()]
    manifest_path = dest / "manifest.json"
    manifest = _read_manifest(manifest_path)
    manifest["dest"] = str(dest)
    known = {e["file"]: e for e in manifest["files"]}
    try:
        for talker in talkers:
            for utt in utterances:
                rel = f"speech/cmu_arctic_us_{talker}_{utt}.wav"
                target = dest / rel
                if target.exists() and rel in known and sha256_of(target) == known[rel]["sha256"]:
                    continue
                url = f"{base_url}cmu_us_{talker}_arctic/wav/arctic_{utt}.wav"
                digest = fetch(url, target, timeout_s=timeout_s)
                known[rel] = {"file": rel, "talker": talker, "utterance": utt, "url": url,
                              "bytes": target.stat().st_size, "sha256": digest}
                manifest["files"] = sorted(known.values(), key=lambda e: e["file"])
                manifest_path.write_text(json.dumps(manifest, indent=2) + "\n")
    except DownloadError as exc:
        _remove_empty(created)
        raise DataError(f"CMU ARCTIC download failed: {exc}. {OFFLINE_HINT}") from exc
    return manifest


def _read_manifest(path: Path) -> dict:
    if path.exists():
        try:
            data = json.loads(path.read_text())
            if isinstance(data, dict) and isinstance(data.get("files"), list):
                return data
        except (OSError, ValueError):
            pass
    return {"recipe": "cmu-arctic", "license": "CMU ARCTIC: free for use for any purpose",
            "files": []}


def _remove_empty(created: list[Path]) -> None:
    """Remove the directories this call created, deepest first, if nothing is left in them."""
    for path in sorted(created, key=lambda p: len(p.parts), reverse=True):
        if path.is_dir() and not any(path.iterdir()):
            shutil.rmtree(path, ignore_errors=True)
