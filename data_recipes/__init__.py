"""Corpora and noise for scenesim: built-in artificial voice, local folders, downloadable corpora, noise synthesis.

The benchmark runner needs only :func:`open_data`::

    ds = data_recipes.open_data(data_dir, fs=16000)
    clip = ds.speech(10.0, seed=1)            # Clip(signal, fs, source, files)
    clip = ds.noise("babble", 10.0, seed=1, n_channels=2)

Recipes that write a data directory: :func:`list_recipes`, :func:`prepare`.

The names below load on first use (:mod:`scenesim.lazy`): ``import data_recipes`` does not import
the artificial voice's scipy.signal for a caller that wants the LTASS table.
"""

from __future__ import annotations

from scenesim.lazy import lazy_exports

# public name -> the module that defines it
_SOURCES = {
    "TALKERS": "data_recipes.artificial_voice",
    "Talker": "data_recipes.artificial_voice",
    "artificial_voice": "data_recipes.artificial_voice",
    "prepare_cmu_arctic": "data_recipes.cmu_arctic",
    "prepare_local": "data_recipes.local",
    "scan_local": "data_recipes.local",
    "SYNTHESIZABLE": "data_recipes.noise_synthesis",
    "SynthesizedNoise": "data_recipes.noise_synthesis",
    "synthesize_noise": "data_recipes.noise_synthesis",
    "prepare_noisex92": "data_recipes.noisex92",
    "Recipe": "data_recipes.registry",
    "get_recipe": "data_recipes.registry",
    "list_recipes": "data_recipes.registry",
    "prepare": "data_recipes.registry",
    "Clip": "data_recipes.source",
    "DataFallbackWarning": "data_recipes.source",
    "DataSource": "data_recipes.source",
    "open_data": "data_recipes.source",
}

__all__ = sorted(_SOURCES)
__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)
