"""Corpora and noise for scenesim: built-in artificial voice, local folders, downloadable corpora, noise synthesis."""
