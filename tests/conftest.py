"""Shared fixtures: seeded randomness, the real audio in ../shared (skipped with a reason when absent)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

# Headless plots everywhere in the suite.
os.environ.setdefault("MPLBACKEND", "Agg")

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = Path(os.environ.get("SCENESIM_SHARED", REPO_ROOT.parent / "shared"))


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every test that draws random numbers draws the same ones every run."""
    return np.random.default_rng(20121122)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """``../shared`` beside the checkout (or ``$SCENESIM_SHARED``); skip when it is not there."""
    if not SHARED_DIR.is_dir():
        pytest.skip(f"shared material not found at {SHARED_DIR} (set SCENESIM_SHARED)")
    return SHARED_DIR


@pytest.fixture(scope="session")
def shared_data_dir(shared_dir: Path) -> Path:
    """``../shared/data``: real CMU ARCTIC speech and real noise recordings (never copied into the repo)."""
    data = shared_dir / "data"
    if not (data / "speech").is_dir():
        pytest.skip(f"real audio not found at {data}/speech")
    return data
