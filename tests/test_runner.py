"""The runner: pure units, rendering reuse, resume, retry of errors, executors agreeing."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.run import worker
from benchmarks.run.runner import (
    ConditionTask,
    EnhancerSpec,
    UnitTask,
    plan_conditions,
    plan_units,
    run_condition,
    run_sweep,
    run_unit,
)
from benchmarks.run.sweep import parse_sweep
from benchmarks.store.sqlite import ResultStore
from scenesim.errors import ConfigError, DataError, ParameterError

# 1 s of speech keeps each unit well under a second (PESQ/STOI scale with length).
TINY = """\
[sweep]
name = "tiny"

[axes]
enhancers = ["passthrough", "ss"]
noise = ["wind"]
snr_db = [0, 10]

[fixed]
duration_s = 1.5
"""

METRICS = ("snr_out_db", "snr_i_db", "pesq_nb_in", "pesq_nb_out", "pesq_wb_in", "pesq_wb_out", "stoi_in", "stoi_out")


def _metrics(rows):
    return {(r["condition_id"], r["enhancer"]): tuple(r[m] for m in METRICS) for r in rows}


def test_plan_units_skips_done_and_keeps_only_missing_enhancers():
    sweep = parse_sweep(TINY)
    conds = sweep.conditions()
    done = {(conds[0].id, "passthrough"), (conds[0].id, "ss"), (conds[1].id, "ss")}
    tasks = plan_conditions(sweep, conds, done, None)
    assert len(tasks) == 1
    assert tasks[0].condition == conds[1]
    assert [s.name for s in tasks[0].enhancers] == ["passthrough"]


def test_run_unit_is_pure_and_the_render_cache_changes_nothing():
    """Same task -> same numbers, whether the geometry was rendered now or taken from the cache.

    Oracle: the function's own first result (determinism, to 1e-12 relative)."""
    sweep = parse_sweep(TINY)
    cond = sweep.conditions()[0]
    task = ConditionTask(cond.to_json(), (EnhancerSpec("passthrough"), EnhancerSpec("ss")))
    worker._IMAGES.clear()
    first = run_condition(task)
    assert len(worker._IMAGES) == 1  # the geometry group stays cached for the next SNR
    again = run_condition(task)  # from the cache
    worker._IMAGES.clear()
    fresh = run_condition(task)  # rendered anew
    assert [r["status"] for r in first] == ["ok", "ok"], [r["error"] for r in first]
    for a, b, c in zip(first, again, fresh):
        for m in METRICS:
            np.testing.assert_allclose([b[m], c[m]], [a[m], a[m]], rtol=1e-12, err_msg=m)
    row = first[0]
    assert row["condition_id"] == cond.id and row["snr_in_db"] == 0.0 and row["noise"] == "wind"
    assert row["speech_source"] == "artificial-voice" and row["noise_source"] == "synthetic:wind"
    assert json.loads(row["condition_json"])["snr_db"] == 0.0
    assert json.loads(first[1]["enhancer_spec"])["name"] == "ss"


def test_a_condition_that_cannot_be_rendered_gives_error_rows_not_a_crash():
    sweep = parse_sweep(TINY.replace('noise = ["wind"]', 'noise = ["no-such-noise"]'))
    task = ConditionTask(sweep.conditions()[0].to_json(), (EnhancerSpec("passthrough"),))
    (row,) = run_condition(task)
    assert row["status"] == "error" and "no-such-noise" in row["error"]


def test_an_enhancer_that_cannot_be_built_gives_an_error_row():
    cond = parse_sweep(TINY).conditions()[0]
    task = ConditionTask(cond.to_json(), (EnhancerSpec("passthrough"), EnhancerSpec("ss", json.dumps({"nonsense": 1}))))
    ok, bad = run_condition(task)
    assert ok["status"] == "ok" and bad["status"] == "error" and "nonsense" in bad["error"]


def test_resume_computes_only_what_is_missing(tmp_path):
    sweep = parse_sweep(TINY)
    first = run_sweep(sweep, tmp_path, workers=1, limit=1, report=False, progress=False)
    assert (first.n_conditions, first.n_computed, first.n_rows) == (1, 1, 2)
    with ResultStore.open(tmp_path) as store:
        before = {(r["condition_id"], r["enhancer"]): r["created_at"] for r in store.rows()}
    second = run_sweep(sweep, tmp_path, workers=1, report=False, progress=False)
    assert (second.n_conditions, second.n_computed, second.n_skipped, second.n_rows) == (2, 1, 1, 2)
    third = run_sweep(sweep, tmp_path, workers=1, report=False, progress=False)
    assert (third.n_computed, third.n_rows) == (0, 0)
    with ResultStore.open(tmp_path) as store:
        rows = store.rows()
        runs = store.runs()
    assert len(rows) == 4 and all(r["status"] == "ok" for r in rows)
    for r in rows:  # rows of the first run untouched
        key = (r["condition_id"], r["enhancer"])
        if key in before:
            assert r["created_at"] == before[key] and r["run_id"] == first.run_id
    assert [r["status"] for r in runs] == ["finished"] * 3


def test_error_rows_are_kept_unless_retry_errors(tmp_path):
    sweep = parse_sweep(TINY)
    cond = sweep.conditions()[0]
    with ResultStore.open(tmp_path) as store:
        store.write_rows([{"condition_id": cond.id, "enhancer": "ss", "status": "error", "error": "earlier crash"}])
    s1 = run_sweep(sweep, tmp_path, workers=1, limit=1, report=False, progress=False)
    assert s1.n_rows == 1  # passthrough only; the error row counts as done
    s2 = run_sweep(sweep, tmp_path, workers=1, limit=1, retry_errors=True, report=False, progress=False)
    assert s2.n_rows == 1
    with ResultStore.open(tmp_path) as store:
        assert {r["enhancer"]: r["status"] for r in store.rows()} == {"ss": "ok", "passthrough": "ok"}


def test_process_pool_gives_the_same_numbers_as_serial(tmp_path):
    """Oracle: the serial run; a pure unit function must give identical metrics (1e-9)."""
    sweep = parse_sweep(TINY)
    run_sweep(sweep, tmp_path / "serial", workers=1, report=False, progress=False)
    summary = run_sweep(sweep, tmp_path / "pool", workers=2, report=False, progress=False)
    assert summary.n_rows == 4
    with ResultStore.open(tmp_path / "serial") as a, ResultStore.open(tmp_path / "pool") as b:
        ma, mb = _metrics(a.rows()), _metrics(b.rows())
    assert ma.keys() == mb.keys()
    for key in ma:
        np.testing.assert_allclose(np.array(mb[key], float), np.array(ma[key], float), rtol=0, atol=1e-9)


def test_seed_offsets_the_seeds_and_limit_is_checked(tmp_path):
    summary = run_sweep(parse_sweep(TINY), tmp_path, workers=1, limit=1, seed=3, report=False, progress=False)
    with ResultStore.open(tmp_path) as store:
        assert {r["seed"] for r in store.rows()} == {3}
    assert summary.n_rows == 2
    with pytest.raises(ParameterError, match="limit"):
        run_sweep(parse_sweep(TINY), tmp_path, limit=0, report=False)
    with pytest.raises(ParameterError, match="executor"):
        run_sweep(parse_sweep(TINY), tmp_path, executor="mpi", report=False)


def test_units_are_whole_geometry_groups_only_when_there_are_enough_groups():
    sweep = parse_sweep(TINY.replace('snr_db = [0, 10]', 'snr_db = [0, 10]\nspeech_az_deg = [0, 30, 60, 90, 120, 150, 180, 210]'))
    tasks = plan_conditions(sweep, sweep.conditions(), set(), None)
    assert len(tasks) == 16
    per_group = plan_units(tasks, workers=2)  # 8 groups >= 4 per worker: one unit per group
    assert [len(u) for u in per_group] == [2] * 8
    assert all(len({t.condition.group_id for t in u.conditions}) == 1 for u in per_group)
    assert [len(u) for u in plan_units(tasks, workers=3)] == [1] * 16  # too few groups for 3
    assert [len(u) for u in plan_units(tasks, workers=1)] == [1] * 16  # serial: finest grain
    rows = run_unit(UnitTask(tuple(tasks[:2])))
    assert [[r["snr_in_db"] for r in per_cond] for per_cond in rows] == [[0.0, 0.0], [10.0, 10.0]]


def test_unknown_noise_type_or_data_dir_fails_before_anything_runs(tmp_path):
    sweep = parse_sweep(TINY.replace('noise = ["wind"]', 'noise = ["no-such-noise"]'))
    with pytest.raises(ConfigError, match="no-such-noise"):
        run_sweep(sweep, tmp_path / "a", workers=1, report=False, progress=False)
    with pytest.raises(DataError, match="nowhere"):
        run_sweep(parse_sweep(TINY), tmp_path / "b", data_dir=tmp_path / "nowhere", workers=1, report=False)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_enhancer_params_and_geometry_reach_the_enhancer(tmp_path):
    """``[enhancer_params.eb] mu = ...`` is used, and the scene's spacing overrides the default."""
    text = TINY.replace('["passthrough", "ss"]', '["passthrough", "eb"]').replace(
        "duration_s = 1.5", "duration_s = 1.5\nspacing_m = 0.03"
    ) + "\n[enhancer_params.eb]\nmu = 0.02\n"
    sweep = parse_sweep(text)
    summary = run_sweep(sweep, tmp_path, workers=1, limit=1, report=False, progress=False)
    assert summary.n_rows == 2
    with ResultStore.open(tmp_path) as store:
        eb = next(r for r in store.rows() if r["enhancer"] == "eb")
    spec = json.loads(eb["enhancer_spec"])
    assert spec["name"] == "eb" and spec["params"]["mu"] == 0.02 and spec["params"]["spacing_m"] == 0.03
    assert eb["status"] == "ok"


def test_resuming_on_other_data_warns_that_old_rows_are_kept(tmp_path, shared_data_dir):
    sweep = parse_sweep(TINY.replace('["passthrough", "ss"]', '["passthrough"]'))
    run_sweep(sweep, tmp_path, workers=1, limit=1, report=False, progress=False)
    with pytest.warns(UserWarning, match="computed with data built-in and are kept"):
        summary = run_sweep(sweep, tmp_path, workers=1, data_dir=shared_data_dir, report=False, progress=False)
    assert summary.n_computed == 1  # only the missing condition, on the new data
