"""The data recipes by name: :func:`list_recipes` and :func:`prepare`."""

from __future__ import annotations

import inspect
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from data_recipes.artificial_voice import TALKERS, artificial_voice
from data_recipes.cmu_arctic import prepare_cmu_arctic
from data_recipes.download import cache_dir
from data_recipes.local import prepare_local, sha256_of
from data_recipes.noise_synthesis import synthesize_noise
from data_recipes.noisex92 import prepare_noisex92
from scenesim.audio import write_audio
from scenesim.errors import ParameterError
from scenesim.validate import check_fs, check_int, check_positive


@dataclass(frozen=True)
class Recipe:
    """A named way to obtain data: ``prepare(dest, **options) -> manifest dict``."""

    name: str
    summary: str
    needs_network: bool
    needs_src: bool
    prepare: Callable[..., dict]


def prepare_artificial_voice(
    dest: Path | str | None = None,
    *,
    fs: int = 16000,
    duration_s: float = 10.0,
    seed: int = 0,
    noise_s: float = 30.0,
) -> dict:
    """Write the built-in data as a data directory: one clip per artificial talker + noises.

    ``dest/speech/artificial-voice_<talker>.wav`` (``duration_s`` each, 16-bit) for the
    six talkers of :data:`~data_recipes.artificial_voice.TALKERS`, and, unless
    ``noise_s == 0``, ``dest/noise/{babble,factory,wind}_synthetic.wav`` of ``noise_s``
    seconds, plus ``manifest.json``.  Default ``dest``: ``<cache>/artificial-voice``.
    """
    fs = check_fs(fs)
    duration_s = check_positive("duration_s", duration_s)
    seed = check_int("seed", seed, minimum=0)
    noise_s = check_positive("noise_s", noise_s, allow_zero=True)
    dest = Path(dest).expanduser() if dest is not None else cache_dir() / "artificial-voice"
    (dest / "speech").mkdir(parents=True, exist_ok=True)
    files = []
    for k, talker in enumerate(TALKERS):
        x, _ = artificial_voice(duration_s, fs=fs, seed=seed + k, talker=talker)
        rel = f"speech/artificial-voice_{talker.name}.wav"
        write_audio(dest / rel, x, fs, subtype="PCM_16", normalize=True)
        files.append({"file": rel, "talker": talker.name, "sex": talker.sex, "seed": seed + k,
                      "duration_s": x.size / fs, "fs": fs, "sha256": sha256_of(dest / rel)})
    if noise_s > 0:
        (dest / "noise").mkdir(exist_ok=True)
        for j, noise_type in enumerate(("babble", "factory", "wind")):
            rng = np.random.default_rng([seed, 1000 + j])
            synth = synthesize_noise(noise_type, int(round(noise_s * fs)), fs=fs, rng=rng)
            rel = f"noise/{noise_type}_synthetic.wav"
            write_audio(dest / rel, synth.signal[0], fs, subtype="PCM_16", normalize=True)
            files.append({"file": rel, "noise_type": noise_type, "components": list(synth.components),
                          "duration_s": noise_s, "fs": fs, "sha256": sha256_of(dest / rel)})
    manifest = {"recipe": "artificial-voice", "dest": str(dest), "files": files}
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest


def _prepare_local(dest=None, *, src=None, fs=None, strict=True) -> dict:
    if src is None:
        raise ParameterError("src", src, "the folder to validate (speech/, noise/)")
    return prepare_local(src, dest, fs=fs, strict=strict)


def _prepare_noisex92(dest=None, *, src=None, fs=16000, min_duration_s=60.0) -> dict:
    if src is None:
        raise ParameterError("src", src, "the folder holding the NOISEX-92 files (babble.wav, ...)")
    dest = Path(dest).expanduser() if dest is not None else cache_dir() / "noisex92"
    return prepare_noisex92(src, dest, fs=fs, min_duration_s=min_duration_s)


_RECIPES = (
    Recipe("artificial-voice", "built-in P.50-like artificial voices (3 male, 3 female) "
           "and synthesized babble/factory/wind; offline", False, False, prepare_artificial_voice),
    Recipe("local", "validate a folder with speech/ and noise/<type>_*.wav (reports bad files, "
           "writes manifest.json with sha256; converts into --dest)", False, True, _prepare_local),
    Recipe("cmu-arctic", "download CMU ARCTIC utterances (festvox.org) with sha256 manifest; "
           "resumable; needs internet", True, False, prepare_cmu_arctic),
    Recipe("noisex92", "convert user-supplied NOISEX-92 files (babble.wav, factory1.wav, ...) "
           "into noise/<type>_noisex92.wav", False, True, _prepare_noisex92),
)


def list_recipes() -> tuple[Recipe, ...]:
    """Every data recipe, in a stable order."""
    return _RECIPES


def get_recipe(name: str) -> Recipe:
    """The recipe called ``name``."""
    for recipe in _RECIPES:
        if recipe.name == name:
            return recipe
    raise ParameterError("recipe", name, "one of " + ", ".join(r.name for r in _RECIPES))


def prepare(name: str, dest: Path | str | None = None, **options) -> dict:
    """Run recipe ``name`` into ``dest`` (recipe default when ``None``); return its manifest.

    Options per recipe: ``artificial-voice`` (fs, duration_s, seed, noise_s); ``local``
    (src, fs, strict); ``cmu-arctic`` (talkers, utterances, base_url, timeout_s);
    ``noisex92`` (src, fs, min_duration_s).
    """
    recipe = get_recipe(name)
    params = inspect.signature(recipe.prepare).parameters
    allowed = [k for k, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY]
    for key in sorted(options):
        if key not in allowed:
            raise ParameterError(key, options[key], f"an option of recipe {name!r}: " + ", ".join(allowed))
    return recipe.prepare(dest, **options)
