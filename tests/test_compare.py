"""``scenesim bench compare`` (paired CIs over seeds) and ``benchmarks.load_results``, on
hand-made stores."""

from __future__ import annotations

import csv
import json
import sys

import numpy as np
import pytest
from scipy import stats

import benchmarks
from benchmarks.cli.main import main
from benchmarks.report.compare import SweepMismatch, compare_rows, paired_ci
from benchmarks.store.sqlite import CONTRACT_COLUMNS, ResultStore
from scenesim.errors import ScenesimError

SEEDS = (0, 1, 2, 3, 4)
GROUPS = (("babble", 0.0), ("babble", 10.0), ("wind", 0.0))
ENHANCERS = ("eb", "ss")


def _store(path, values: dict, *, drop=(), errors=()):
    """A store of ``values[(noise, snr, seed, enhancer)] = (snr_i_db, pesq_nb_out)`` rows."""
    rows = []
    for (noise, snr, seed, name), (snr_i, pesq) in values.items():
        cid = f"{noise}-{snr:g}-{seed}"
        if cid in drop:
            continue
        rows.append({
            "condition_id": cid, "enhancer": name, "noise": noise, "snr_in_db": snr, "rt60_s": 0.0,
            "speech_az_deg": 45.0, "noise_az_deg": 270.0, "seed": seed, "snr_i_db": snr_i,
            "pesq_nb_out": pesq, "stoi_out": 0.9, "status": "error" if (cid, name) in errors else "ok",
        })  # fmt: skip
    with ResultStore.open(path) as store:
        store.write_rows(rows)
    return path


@pytest.fixture
def stores(tmp_path, rng):
    base = {
        (n, s, seed, e): (rng.normal(10, 2), rng.normal(2.5, 0.3))
        for n, s in GROUPS
        for seed in SEEDS
        for e in ENHANCERS
    }
    shifted = {k: (a + rng.normal(0.5, 0.4), p + rng.normal(-0.1, 0.05)) for k, (a, p) in base.items()}
    return base, shifted, _store(tmp_path / "a", base), _store(tmp_path / "b", shifted)


def test_paired_ci_matches_scipy_ttest_rel(rng):
    a = rng.normal(3.0, 1.0, 7)
    b = a + rng.normal(0.4, 0.3, 7)
    s = paired_ci(list(a), list(b))
    # oracle: scipy's paired t test and its confidence interval (tolerance 1e-12)
    ci = stats.ttest_rel(b, a).confidence_interval(0.95)
    assert (s.n, s.ci_low, s.ci_high) == (7, pytest.approx(ci.low, abs=1e-12), pytest.approx(ci.high, abs=1e-12))
    assert s.mean_diff == pytest.approx(np.mean(b - a), abs=1e-12)
    assert s.sd_diff == pytest.approx(np.std(b - a, ddof=1), abs=1e-12)
    one = paired_ci([1.0], [1.5])
    assert (one.n, one.mean_diff, one.ci_low, one.ci_high) == (1, 0.5, None, None)
    assert paired_ci([], []).n == 0


def test_compare_groups_over_seeds_against_scipy(stores, tmp_path, capsys):
    base, shifted, dir_a, dir_b = stores
    assert main(["bench", "compare", str(dir_a), str(dir_b), "--out", str(tmp_path / "cmp")]) == 0
    out = capsys.readouterr().out
    assert "| ss | babble | 10 | 5 |" in out
    with open(tmp_path / "cmp" / "compare.csv", newline="") as f:
        records = list(csv.DictReader(f))
    assert len(records) == len(GROUPS) * len(ENHANCERS) * 6  # six default metrics
    for rec in records:
        if rec["metric"] not in ("snr_i_db", "pesq_nb_out"):
            continue
        k = 0 if rec["metric"] == "snr_i_db" else 1
        key = (rec["noise"], float(rec["snr_db"]))
        a = np.array([base[(*key, s, rec["enhancer"])][k] for s in SEEDS])
        b = np.array([shifted[(*key, s, rec["enhancer"])][k] for s in SEEDS])
        ci = stats.ttest_rel(b, a).confidence_interval(0.95)
        assert int(rec["n"]) == len(SEEDS)
        # CSV round trip of floats (repr): tolerance 1e-12
        assert float(rec["ci_low"]) == pytest.approx(ci.low, abs=1e-12)
        assert float(rec["ci_high"]) == pytest.approx(ci.high, abs=1e-12)
        assert float(rec["mean_diff"]) == pytest.approx(np.mean(b - a), abs=1e-12)
    assert (tmp_path / "cmp" / "compare.md").read_text().count("\n| ") == 1 + len(GROUPS) * len(ENHANCERS)


def test_error_rows_are_left_out_of_the_pairs(stores, tmp_path):
    base, shifted, dir_a, _ = stores
    dir_b = _store(tmp_path / "b2", shifted, errors={("wind-0-3", "eb")})
    with ResultStore.open(dir_a, readonly=True) as sa, ResultStore.open(dir_b, readonly=True) as sb:
        records, notes = compare_rows(sa.rows(), sb.rows(), metrics=("snr_i_db",))
    rec = next(r for r in records if r["enhancer"] == "eb" and r["noise"] == "wind")
    assert rec["n"] == len(SEEDS) - 1
    assert notes == ["1 (condition, enhancer) pair(s) left out: status 'error' in A or B"]


def test_compare_refuses_different_sweeps_in_one_line(stores, tmp_path, capsys):
    _, shifted, dir_a, _ = stores
    dir_b = _store(tmp_path / "b3", shifted, drop={"babble-10-2"})
    assert main(["bench", "compare", str(dir_a), str(dir_b)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "different sweeps: 1 condition(s) only in A, 0 only in B" in err
    assert "sweep parameters A -> B: unknown" in err  # hand-made stores record no sweep
    with pytest.raises(SweepMismatch, match="share no enhancer"):
        compare_rows([{"condition_id": "c", "enhancer": "eb"}], [{"condition_id": "c", "enhancer": "ss"}])


# -- load_results ----------------------------------------------------------------------------


def test_load_results_gives_a_dataframe(stores):
    pytest.importorskip("pandas")
    base, _, dir_a, _ = stores
    df = benchmarks.load_results(dir_a)
    assert len(df) == len(base)
    assert list(df.columns[: len(CONTRACT_COLUMNS)]) == [c for c, _ in CONTRACT_COLUMNS]
    got = df.set_index(["condition_id", "enhancer"])["snr_i_db"]
    for (noise, snr, seed, name), (snr_i, _) in base.items():
        assert got[(f"{noise}-{snr:g}-{seed}", name)] == snr_i  # stored REAL round-trips exactly
    mean = df.groupby("enhancer")["snr_i_db"].mean()
    assert mean["eb"] == pytest.approx(np.mean([v[0] for k, v in base.items() if k[3] == "eb"]), abs=1e-12)


def test_load_results_without_pandas_names_the_install(stores, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas now raises ImportError
    with pytest.raises(ScenesimError, match=r"^benchmarks.load_results needs pandas: pip install pandas$"):
        benchmarks.load_results(stores[2])


# -- what differs, unchanged lines, seeds that differ ------------------------------------------


def _with_config(path, **changes):
    """Record the smoke sweep's config (with ``changes`` to its axes) as the store's sweep."""
    from benchmarks.run.sweep import load_sweep
    from benchmarks.run.versioning import META_CONFIG, sweep_config

    config = sweep_config(load_sweep("smoke"))
    config["axes"].update(changes)
    with ResultStore.open(path) as store:
        store.set_meta(META_CONFIG, json.dumps(config))
    return path


def test_compare_prints_the_changed_parameters_and_hides_unchanged_lines(stores, tmp_path, capsys):
    base, shifted, dir_a, _ = stores
    same_ss = {k: (base[k] if k[3] == "ss" else v) for k, v in shifted.items()}
    dir_b = _with_config(_store(tmp_path / "b4", same_ss), duration_s=[3.0])
    _with_config(dir_a)
    assert main(["bench", "compare", str(dir_a), str(dir_b), "--out", str(tmp_path / "c4")]) == 0
    out = capsys.readouterr().out
    assert "Sweep parameters that differ (A -> B): duration_s 2.0 -> 3.0." in out
    assert "| ss |" not in out and "| eb |" in out
    assert f"{len(GROUPS)} line(s) where no metric changed are hidden (--all shows them)" in out
    assert main(["bench", "compare", str(dir_a), str(dir_b), "--out", str(tmp_path / "c5"), "--all"]) == 0
    assert "| ss |" in capsys.readouterr().out


def test_stores_that_differ_only_in_seeds_are_compared_unpaired(stores, tmp_path, rng):
    base, _, dir_a, _ = stores
    other = {(n, s, seed + 10, e): (rng.normal(11, 2), rng.normal(2.4, 0.3))
             for (n, s, seed, e) in base if seed < 3}  # fmt: skip
    dir_b = _store(tmp_path / "b5", other)
    with ResultStore.open(dir_a, readonly=True) as sa, ResultStore.open(dir_b, readonly=True) as sb:
        records, notes = compare_rows(sa.rows(), sb.rows(), metrics=("snr_i_db",))
    assert any("compared **unpaired**" in n and "A: 5 seed(s)" in n and "B: 3 seed(s)" in n for n in notes)
    for rec in records:
        key = (rec["noise"], float(rec["snr_db"]))
        a = [base[(*key, s, rec["enhancer"])][0] for s in SEEDS]
        b = [other[(*key, s + 10, rec["enhancer"])][0] for s in range(3)]
        # oracle: scipy's Welch test and its interval (tolerance 1e-12)
        ci = stats.ttest_ind(b, a, equal_var=False).confidence_interval(0.95)
        assert not rec["paired"] and rec["n"] == 3
        assert (rec["ci_low"], rec["ci_high"]) == (pytest.approx(ci.low, abs=1e-12), pytest.approx(ci.high, abs=1e-12))
        assert rec["mean_diff"] == pytest.approx(np.mean(b) - np.mean(a), abs=1e-12)


def test_load_results_accepts_the_sweep_axis_names(stores):
    pytest.importorskip("pandas")
    base, _, dir_a, _ = stores
    df = benchmarks.load_results(dir_a, snr_db=[0.0], enhancers="eb", seeds=(0, 1))
    want = {(n, s, seed, e) for (n, s, seed, e) in base if s == 0.0 and e == "eb" and seed in (0, 1)}
    assert len(df) == len(want) == 4 and set(df["snr_in_db"]) == {0.0} and set(df["enhancer"]) == {"eb"}
    assert len(benchmarks.load_results(dir_a, snr_in_db=10.0)) == len([k for k in base if k[1] == 10.0])
    with pytest.raises(ScenesimError, match="no column 'snr'"):
        benchmarks.load_results(dir_a, snr=0)


def _rows(diffs_by_snr, *, offset=0.0, with_json=True, seeds=(0, 1, 2)):
    """Rows of one enhancer: per SNR and seed a condition; snr_i_db = seed + offset + diff(snr)."""
    rows = []
    for snr, diff in diffs_by_snr.items():
        for seed in seeds:
            params = {"noise": "babble", "snr_db": snr, "seed": seed}
            rows.append({"condition_id": f"c{snr}-{seed}", "enhancer": "eb", "status": "ok", "seed": seed,
                         "noise": "babble", "snr_in_db": float(snr), "rt60_s": 0.0, "speech_az_deg": 45.0,
                         "noise_az_deg": 270.0, "snr_i_db": seed * 0.7 + offset + diff,
                         "condition_json": json.dumps(params) if with_json else None})
    return rows


@pytest.mark.parametrize("with_json", [True, False])
def test_compare_groups_over_seeds_by_every_other_condition_parameter(with_json):
    # Oracle: B - A is exactly 1 dB at 0 dB SNR and 3 dB at 10 dB for every seed, so each SNR is
    # one group of n = 3 seeds with mean difference 1 and 3 and zero spread.  Grouping by seed too
    # (6 groups of 1) or not by SNR (one group, mean 2) fails; with or without condition_json.
    a = _rows({0: 0.0, 10: 0.0}, with_json=with_json)
    b = _rows({0: 1.0, 10: 3.0}, with_json=with_json)
    records, _ = compare_rows(a, b, metrics=("snr_i_db",))
    got = sorted((r["snr_db"], r["n"], r["mean_diff"], r["sd_diff"]) for r in records)
    assert got == [(0.0, 3, pytest.approx(1.0), pytest.approx(0.0)), (10.0, 3, pytest.approx(3.0), pytest.approx(0.0))]


def test_load_results_keeps_a_stores_extra_columns_with_their_values(tmp_path):
    # Oracle: the values written.  A column this version's schema lacks (one a newer scenesim
    # or a plugin added to the table) comes back in the frame with its value, after the schema's.
    import sqlite3

    from benchmarks.store.sqlite import ResultStore

    pytest.importorskip("pandas")
    with ResultStore.open(tmp_path) as store:
        store.write_rows([{"condition_id": "c1", "enhancer": "eb", "status": "ok", "snr_i_db": 4.5}])
    with sqlite3.connect(tmp_path / "results.sqlite") as db:
        db.execute("ALTER TABLE results ADD COLUMN plugin_score REAL")
        db.execute("UPDATE results SET plugin_score = 1.25")
    df = benchmarks.load_results(tmp_path)
    assert df.loc[0, "snr_i_db"] == 4.5 and df.loc[0, "plugin_score"] == 1.25
    assert list(df.columns[:2]) == ["condition_id", "enhancer"] and df.columns[-1] == "plugin_score"
