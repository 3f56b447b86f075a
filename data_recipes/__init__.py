"""Corpora and noise for scenesim: built-in artificial voice, local folders, downloadable corpora, noise synthesis.

The benchmark runner needs only :func:`open_data`::

    ds = data_recipes.open_data(data_dir, fs=16000)
    clip = ds.speech(10.0, seed=1)            # Clip(signal, fs, source, files)
    clip = ds.noise("babble", 10.0, seed=1, n_channels=2)

Recipes that write a data directory: :func:`list_recipes`, :func:`prepare`.
"""

from data_recipes.artificial_voice import TALKERS, Talker, artificial_voice
from data_recipes.cmu_arctic import prepare_cmu_arctic
from data_recipes.local import prepare_local, scan_local
from data_recipes.noise_synthesis import SYNTHESIZABLE, SynthesizedNoise, synthesize_noise
from data_recipes.noisex92 import prepare_noisex92
from data_recipes.registry import Recipe, get_recipe, list_recipes, prepare
from data_recipes.source import Clip, DataFallbackWarning, DataSource, open_data

__all__ = [
    "TALKERS",
    "SYNTHESIZABLE",
    "Clip",
    "DataFallbackWarning",
    "DataSource",
    "Recipe",
    "SynthesizedNoise",
    "Talker",
    "artificial_voice",
    "get_recipe",
    "list_recipes",
    "open_data",
    "prepare",
    "prepare_cmu_arctic",
    "prepare_local",
    "prepare_noisex92",
    "scan_local",
    "synthesize_noise",
]
