"""Where a benchmark's speech and noise come from: :func:`open_data` and :class:`DataSource`.

Resolution order (contract.md, "Data directories"): the ``data_dir`` argument, else
the ``SCENESIM_DATA`` environment variable, else the built-in recipes (artificial
voice + synthesized noises).  A noise type the directory lacks is synthesized with a
:class:`DataFallbackWarning` naming it; every clip says where it came from
(:attr:`Clip.source`, :attr:`Clip.files`), for the results' ``speech_source`` /
``noise_source`` columns.
"""

from __future__ import annotations

import json
import os
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from data_recipes.artificial_voice import OUTPUT_RMS, artificial_voice
from data_recipes.local import AudioEntry, LocalScan, load_mono, scan_local
from data_recipes.noise_synthesis import (
    NOISE_RMS,
    SYNTHESIZABLE,
    SpeechPoolItem,
    _artificial_babble_bank,
    synthesize_noise,
)
from data_recipes.splits import SPLITS, Portion, SplitPlan, plan_split, split_pool, split_seed
from scenesim.errors import DataError, ParameterError
from scenesim.validate import check_choice, check_fs, check_int, check_positive

#: Environment variable naming the data directory.
DATA_ENV = "SCENESIM_DATA"

_PAUSE_S = (0.2, 0.5)  # pause between concatenated utterances
_CROSSFADE_S = 0.02  # raised-cosine crossfade where a noise file loops


class DataFallbackWarning(UserWarning):
    """A requested noise type is missing from the data directory and is synthesized instead."""


@dataclass(frozen=True)
class Clip:
    """A piece of speech or noise and its provenance.

    Attributes
    ----------
    signal : ndarray
        Shape ``(n,)`` for one channel, ``(n_channels, n)`` for more.
    fs : int
        Sampling rate (Hz).
    source : str
        ``"artificial-voice"``, ``"local:<dir>"``, ``"synthetic:<type>"``.
    files : tuple of str
        The files (or recipe + seed / components) that made it.
    """

    signal: np.ndarray
    fs: int
    source: str
    files: tuple[str, ...]


def open_data(
    data_dir: str | os.PathLike | None = None, *, fs: int = 16000, require_speech: bool = False,
    split: str = "all",
) -> DataSource:
    """Open the data source: ``data_dir`` > ``$SCENESIM_DATA`` > built-in.

    Parameters
    ----------
    data_dir : path, optional
        A data directory with ``speech/`` and/or ``noise/``.
    fs : int
        Sampling rate (Hz) every clip is delivered at.
    require_speech : bool
        The directory was chosen explicitly (``--data-dir``): no usable speech in it is an
        error instead of a fallback to the built-in voice.
    split : {"all", "dev", "test"}
        The material drawn from (:mod:`data_recipes.splits`); ``"all"``: every file and seed.

    Raises
    ------
    DataError
        If the directory does not exist or holds no usable audio at all (or, with
        ``require_speech``, no usable speech).
    ConfigError
        If the directory's ``splits.toml`` is malformed (only read for ``dev`` / ``test``).
    """
    fs = check_fs(fs)
    if data_dir is None:
        env = os.environ.get(DATA_ENV, "").strip()
        data_dir = env or None
    return DataSource(None if data_dir is None else Path(data_dir), fs=fs, require_speech=require_speech,
                      split=split)


class DataSource:
    """Speech and noise at one sampling rate, from a data directory or the built-in recipes.

    Parameters
    ----------
    root : Path or None
        A data directory; ``None`` for the built-in recipes.
    fs : int
        Sampling rate (Hz) of every clip.
    split : {"all", "dev", "test"}
        Draw only this split's material (:mod:`data_recipes.splits`): its files or file
        segments, and for built-in material its generator seeds (:func:`~data_recipes.splits.split_seed`).

    Notes
    -----
    Unusable files of a directory are skipped with a :class:`DataFallbackWarning` naming
    each; a directory with no usable file at all raises :class:`DataError`.  A directory
    without usable speech falls back to the artificial voice (with a warning).
    Instances pickle (for process pools / Dask): decoded audio is cached per instance.
    """

    def __init__(self, root: Path | None, *, fs: int = 16000, require_speech: bool = False, split: str = "all"):
        self.fs = check_fs(fs)
        self.split = check_choice("split", split, SPLITS)
        self._plan: SplitPlan | None = None
        self.root = None if root is None else Path(root).expanduser().resolve()
        self._cache: dict[Path, np.ndarray] = {}
        self._scan: LocalScan | None = None
        self._kind = "local"
        if self.root is not None:
            scan = scan_local(self.root, hash_files=False)
            if scan.bad:
                warnings.warn(
                    f"skipping {len(scan.bad)} unusable file(s) in {self.root}:\n{scan.bad_report()}",
                    DataFallbackWarning,
                    stacklevel=3,
                )
            if not scan.speech and not scan.noise:
                first = f" ({scan.bad[0].path.name}: {scan.bad[0].reason})" if scan.bad else ""
                raise DataError(
                    f"no usable audio in {self.root}{first}: expected speech/*.wav|flac and "
                    "noise/<type>[_<anything>].wav|flac"
                )
            if not scan.speech and require_speech:
                raise DataError(
                    f"no usable speech in {self.root}/speech (see the skipped files above); add "
                    ".wav/.flac speech there, or leave out --data-dir for the built-in voice"
                )
            if not scan.speech:
                warnings.warn(
                    f"no usable speech in {self.root}/speech; using the built-in artificial voice",
                    DataFallbackWarning,
                    stacklevel=3,
                )
            self._scan = scan
            self._kind = _recipe_of(self.root)
            self._plan = plan_split(scan, self.split)

    # ------------------------------------------------------------------ description
    @property
    def description(self) -> str:
        """``"built-in (artificial voice + synthesized noise)"``, ``"local:<dir>"``, or
        ``"cmu-arctic:<dir>"`` for a directory filled by the ``cmu-arctic`` recipe."""
        if self.root is None:
            return "built-in (artificial voice + synthesized noise)"
        return f"{self._kind}:{self.root}"

    def __repr__(self) -> str:
        return f"DataSource({self.description!r}, fs={self.fs})"

    def noise_types(self) -> tuple[str, ...]:
        """Noise types available: those in the directory plus every synthesizable one."""
        present = self._scan.noise_types if self._scan is not None else ()
        return tuple(sorted(set(present) | set(SYNTHESIZABLE)))

    def plays(self, noise_type: str) -> str | None:
        """The noise type a sweep's ``noise_type`` plays, or None when there is none.

        An available type plays itself; a variant ``<type>-<name>`` that is not available
        itself (``factory-hall``: the factory noise, rendered in its own field) plays ``<type>``.
        """
        available = self.noise_types()
        if not isinstance(noise_type, str):
            return None
        if noise_type not in available and "-" in noise_type:
            noise_type = noise_type.split("-", 1)[0]
        return noise_type if noise_type in available else None

    @property
    def local_noise_types(self) -> tuple[str, ...]:
        """Noise types backed by files of the directory (empty for the built-in source)."""
        return self._scan.noise_types if self._scan is not None else ()

    # ------------------------------------------------------------------ speech
    def speech(self, duration_s: float, *, seed: int) -> Clip:
        """``duration_s`` seconds of clean speech, deterministic per ``seed``.

        From a directory: utterances (of this split) in a seeded random order, each scaled to
        the same RMS, separated by 0.2-0.5 s pauses, looped as needed and cut to length.  Built
        in: the artificial voice of a seed-chosen talker, drawn with the split's seed
        (:func:`~data_recipes.splits.split_seed`).  The clip's RMS is 0.05 (-26 dBFS).
        """
        duration_s = check_positive("duration_s", duration_s)
        seed = split_seed(check_int("seed", seed, minimum=0), self.split)
        n = max(1, int(round(duration_s * self.fs)))
        if self._scan is None or not self._scan.speech:
            x, talker = artificial_voice(duration_s, fs=self.fs, seed=seed)
            return Clip(x[:n], self.fs, "artificial-voice",
                        (f"artificial-voice:{talker.name}:seed={seed}",))
        rng = np.random.default_rng([seed, _tag("speech")])
        portions = self._plan.speech
        order = rng.permutation(len(portions))
        pieces, files, total, k = [], [], 0, 0
        while total < n:
            utt, label = self._load_portion(portions[int(order[k % len(order)])])
            k += 1
            utt = utt * (OUTPUT_RMS / max(np.sqrt(np.mean(utt**2)), 1e-12))
            pause = np.zeros(int(rng.uniform(*_PAUSE_S) * self.fs))
            pieces += [utt, pause]
            files.append(label)
            total += utt.size + pause.size
        x = np.concatenate(pieces)[:n]
        x = x * (OUTPUT_RMS / max(np.sqrt(np.mean(x**2)), 1e-12))
        return Clip(x, self.fs, self.description, tuple(files))

    # ------------------------------------------------------------------ noise
    def noise(self, noise_type: str, duration_s: float, *, seed: int, n_channels: int = 1) -> Clip:
        """``duration_s`` seconds of noise of ``noise_type``, deterministic per ``seed``.

        If the directory has files of this type, a seed-chosen file is looped (20 ms
        crossfade) and read from a seed-chosen offset; with ``n_channels > 1`` each
        channel uses another file of the type when there is one, else the same file at
        offsets ``len/n_channels`` apart.  Otherwise the type is synthesized
        (:func:`~data_recipes.noise_synthesis.synthesize_noise`, babble from this
        source's speech), with a :class:`DataFallbackWarning` when a directory was
        given.  Every channel has RMS 0.1 (-20 dBFS).  A type ``<type>-<name>`` that is not
        available itself is a variant of ``<type>`` and plays its noise (``factory-hall``: the
        factory noise, which a sweep renders in another field).

        Raises
        ------
        ParameterError
            If the type is neither in the directory nor synthesizable.
        """
        duration_s = check_positive("duration_s", duration_s)
        seed = split_seed(check_int("seed", seed, minimum=0), self.split)
        n_channels = check_int("n_channels", n_channels, minimum=1)
        asked, noise_type = noise_type, self.plays(noise_type)
        if noise_type is None:
            # name what the user asked for, not the base type a variant was read as
            raise ParameterError("noise_type", asked, "one of " + ", ".join(self.noise_types())
                                 + " (or a variant '<type>-<name>' of one)")
        n = max(1, int(round(duration_s * self.fs)))
        rng = np.random.default_rng([seed, _tag("noise:" + noise_type)])
        if noise_type in self.local_noise_types:
            return self._noise_from_files(noise_type, n, rng, n_channels)
        if self.root is not None:
            warnings.warn(
                f"noise type {noise_type!r} is not in {self.root}/noise; synthesizing it "
                f"(source 'synthetic:{noise_type}')",
                DataFallbackWarning,
                stacklevel=2,
            )
        pool = self._speech_pool() if noise_type == "babble" else None
        if noise_type == "babble" and pool is None and self.split != "all":
            pool = split_pool(_artificial_babble_bank(self.fs), self.split)  # the bank's split segment
        synth = synthesize_noise(noise_type, n, fs=self.fs, rng=rng, speech_pool=pool, n_channels=n_channels)
        signal = synth.signal[0] if n_channels == 1 else synth.signal
        files = (f"synthetic:{noise_type}:seed={seed}",) + synth.components
        return Clip(signal, self.fs, f"synthetic:{noise_type}", files)

    def _noise_from_files(self, noise_type: str, n: int, rng: np.random.Generator, n_channels: int) -> Clip:
        entries = self._plan.noise[noise_type]
        order = rng.permutation(len(entries))
        offset0 = rng.uniform()
        channels, files = [], []
        for ch in range(n_channels):
            x, label = self._load_portion(entries[int(order[ch % len(entries)])])
            # Spread channels that share a file evenly around its loop.
            share = ch // len(entries)
            n_share = -(-n_channels // len(entries))
            start = int(((offset0 + share / n_share) % 1.0) * x.size)
            y = _loop(x, start + n, self.fs)[start:start + n]
            channels.append(y * (NOISE_RMS / max(np.sqrt(np.mean(y**2)), 1e-12)))
            files.append(f"{label}@{start}")
        signal = channels[0] if n_channels == 1 else np.stack(channels)
        return Clip(signal, self.fs, self.description, tuple(files))

    # ------------------------------------------------------------------ helpers
    def _load(self, entry: AudioEntry) -> np.ndarray:
        x = self._cache.get(entry.path)
        if x is None:
            x = load_mono(entry.path, fs=self.fs)
            self._cache[entry.path] = x
        return x

    def _load_portion(self, portion: Portion) -> tuple[np.ndarray, str]:
        """``(samples, label)`` of a whole file or of its split segment."""
        return portion.cut(self._load(portion.entry))

    def _speech_pool(self) -> list[SpeechPoolItem] | None:
        """The split's speech as babble voices (talker = parsed name, else the file stem)."""
        if self._scan is None or not self._scan.speech:
            return None
        pool = []
        for portion in self._plan.speech:
            signal, label = self._load_portion(portion)
            pool.append(SpeechPoolItem(talker=portion.entry.talker or portion.entry.path.stem, label=label,
                                       signal=signal))
        return pool

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_cache"] = {}  # decoded audio is re-read lazily in the receiving process
        return state


def _recipe_of(root: Path) -> str:
    """``"cmu-arctic"`` when ``root/manifest.json`` says that recipe made the directory, else ``"local"``."""
    try:
        manifest = json.loads((root / "manifest.json").read_text())
    except (OSError, ValueError):
        return "local"
    return "cmu-arctic" if isinstance(manifest, dict) and manifest.get("recipe") == "cmu-arctic" else "local"


def _tag(text: str) -> int:
    """A stable 32-bit number for a string (seeds sub-streams; ``hash()`` is salted per process)."""
    return zlib.crc32(text.encode())


def _loop(x: np.ndarray, n: int, fs: int) -> np.ndarray:
    """Repeat ``x`` to at least ``n`` samples with raised-cosine crossfades at the joins."""
    if x.size >= n:
        return x
    fade = min(int(_CROSSFADE_S * fs), x.size // 4)
    if fade < 1:
        return np.tile(x, -(-n // x.size))
    ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(fade) + 0.5) / fade)
    step = x.size - fade
    reps = -(-(n - fade) // step) + 1
    out = np.zeros(step * reps + fade)
    for r in range(reps):
        seg = x.copy()
        if r > 0:
            seg[:fade] *= ramp
        if r < reps - 1:
            seg[-fade:] *= ramp[::-1]
        out[r * step:r * step + x.size] += seg
    return out
