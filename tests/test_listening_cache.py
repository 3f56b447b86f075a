"""The listening page's re-render is memoised: a second report renders nothing (issue 20)."""

from __future__ import annotations

import numpy as np

from benchmarks.report import listening
from benchmarks.run.runner import run_sweep
from benchmarks.store.sqlite import ResultStore
from scenesim.memo import clear_memory_cache


def test_second_render_comes_from_the_cache_and_equals_the_first(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", str(tmp_path / "cache"))
    run_sweep("smoke", tmp_path / "run", workers=1, limit=1, report=False, progress=False)
    with ResultStore(tmp_path / "run" / "results.sqlite", readonly=True) as store:
        rows = [r for r in store.rows() if r.get("status") == "ok"]
    crow = {r["enhancer"]: r for r in rows}
    want, fs, notes = listening.render_condition(crow, data_dir=None, params={})
    assert not notes
    clear_memory_cache()
    first = listening.render_condition_cached(crow, data_dir=None, params={})
    clear_memory_cache()  # only the disk file is left, as for a new `bench report` process

    def no_render(*args, **kwargs):
        raise AssertionError("rendered again instead of read from the cache")

    monkeypatch.setattr(listening, "render_condition", no_render)
    again, fs2, notes2 = listening.render_condition_cached(crow, data_dir=None, params={})
    assert (fs2, notes2) == (fs, []) and first[1] == fs
    assert list(again) == list(want)
    for name in want:  # oracle: the uncached render (bit-identical through the .npy round trip)
        np.testing.assert_array_equal(again[name], want[name])
