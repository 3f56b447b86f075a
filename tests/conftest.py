"""Shared fixtures: seeded randomness, the real audio in ../shared (skipped with a reason when absent)."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

# Headless plots everywhere in the suite.
os.environ.setdefault("MPLBACKEND", "Agg")

# The disk cache (scenesim.room.cache, data recipes) goes to a fresh directory for the whole
# session, never to the user's ~/.cache/scenesim -- unless the tester chose one.
if "SCENESIM_CACHE" not in os.environ:
    os.environ["SCENESIM_CACHE"] = tempfile.mkdtemp(prefix="scenesim-test-cache-")
    atexit.register(shutil.rmtree, os.environ["SCENESIM_CACHE"], ignore_errors=True)

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


@pytest.fixture(scope="session")
def chromium():
    """The headless Chromium binary the browser tests drive; they skip, with the reason, where there is none."""
    from headless_browser import find_chromium  # tests/ is on sys.path for the test modules

    binary = find_chromium()
    if binary is None:
        pytest.skip("no Chromium found (apt-get install chromium, or set SCENESIM_CHROMIUM)")
    return binary
