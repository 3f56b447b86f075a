"""The sweep saves the listening page's clips; the report encodes them without re-rendering (issue 20)."""

from __future__ import annotations

import json

import numpy as np

from benchmarks.report import listening
from benchmarks.run import listen
from benchmarks.run.runner import run_sweep
from benchmarks.run.sweep import load_sweep
from benchmarks.store.sqlite import ResultStore

#: float32 storage of float64 signals: relative rounding 2**-24 per sample.
FLOAT32_RTOL = 1e-6


def _by_condition(out):
    with ResultStore.open(out, readonly=True) as store:
        rows = store.rows()
    by: dict[str, dict[str, dict]] = {}
    for r in rows:
        by.setdefault(r["condition_id"], {})[r["enhancer"]] = r
    return rows, by


def test_the_sweep_saves_the_clips_of_the_conditions_the_report_picks(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    out = tmp_path / "run"
    run_sweep("smoke", out, workers=1, report=False, progress=False, listen_count=2)
    rows, by = _by_condition(out)
    saved = sorted(p.stem for p in (out / listen.CLIPS_DIRNAME).glob("*.npz"))
    picked = listen.listen_ids(load_sweep("smoke").conditions(), 2)
    # The same pick from the sweep's conditions (runner) and from the stored rows (report).
    assert sorted(picked) == saved == sorted(listening.choose_conditions(rows, count=2))
    cid = picked[0]
    signals, fs = listen.load_clips(out, by[cid])
    assert list(signals) == ["reference", "mixture", *by[cid]]
    # Oracle: the report's re-render from the stored row (the slow path it replaces).
    want, fs_want, notes = listening.render_condition(by[cid], data_dir=None, params={})
    assert fs == fs_want and not notes
    for name, x in want.items():
        np.testing.assert_allclose(signals[name], x, rtol=FLOAT32_RTOL, atol=FLOAT32_RTOL * np.max(np.abs(x)))


def test_the_report_encodes_saved_clips_without_rendering(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    out = tmp_path / "run"
    run_sweep("smoke", out, workers=1, report=False, progress=False, listen_count=2)
    rows, _ = _by_condition(out)

    def no_render(*args, **kwargs):
        raise AssertionError("re-rendered a condition whose clips the sweep saved")

    monkeypatch.setattr(listening, "render_condition", no_render)
    page = listening.build_listening(rows, out / "report", out, listening.ListenOptions(count=2))
    assert len(page.conditions) == 2 and all(len(c.clips) >= 3 for c in page.conditions)
    notes = {n for c in page.conditions for n in c.notes}
    assert notes == {"passthrough: identical to the input mixture, not repeated"}
    assert "saved by the sweep" in page.notes[0]


def test_clips_of_another_run_or_spec_are_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    out = tmp_path / "run"
    run_sweep("smoke", out, workers=1, limit=1, report=False, progress=False, listen_count=1)
    _, by = _by_condition(out)
    crow = next(iter(by.values()))
    assert listen.load_clips(out, crow) is not None
    other_run = {n: {**r, "run_id": "another"} for n, r in crow.items()}
    assert listen.load_clips(out, other_run) is None
    name = next(iter(crow))
    spec = json.dumps({**json.loads(crow[name]["enhancer_spec"]), "changed": 1})
    assert listen.load_clips(out, {**crow, name: {**crow[name], "enhancer_spec": spec}}) is None


def test_no_clips_saved_with_listen_count_zero(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    out = tmp_path / "run"
    run_sweep("smoke", out, workers=1, limit=1, report=False, progress=False, listen_count=0)
    assert not (out / listen.CLIPS_DIRNAME).exists()
