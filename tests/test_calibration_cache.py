"""Calibrated rooms are kept on disk per machine by default (issue 20)."""

from __future__ import annotations

import pytest

from scenesim.memo import clear_memory_cache
from scenesim.room import calibration


def _no_compute(*args, **kwargs):
    raise AssertionError("calibrated again instead of read from the disk cache")


def test_calibration_is_cached_in_the_user_cache_dir_by_default(tmp_path, monkeypatch):
    monkeypatch.delenv("SCENESIM_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    clear_memory_cache()
    first = calibration.calibrate_absorption((4, 3, 2.5), 0.3, fs=8000)
    files = list((tmp_path / "scenesim").glob("*.npy"))
    assert len(files) == 1
    clear_memory_cache()  # a new process (another worker, the report): only the disk is left
    monkeypatch.setattr(calibration, "_calibrate", _no_compute)
    assert (calibration.calibrate_absorption((4, 3, 2.5), 0.3, fs=8000) == first).all()
    with pytest.raises(AssertionError, match="calibrated again"):  # another target is another key
        calibration.calibrate_absorption((4, 3, 2.5), 0.35, fs=8000)


def test_an_empty_scenesim_cache_keeps_calibration_in_memory_only(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    clear_memory_cache()
    calibration.calibrate_absorption((4, 3, 2.5), 0.3, fs=8000)
    assert not (tmp_path / "scenesim").exists()
