"""The results store: contract columns, WAL, uniqueness, upsert, resume keys, run metadata."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from benchmarks.metrics import evaluate
from benchmarks.store.sqlite import COLUMNS, CONTRACT_COLUMNS, ResultStore
from scenesim.errors import DataError

# contract.md, "Results store (fixed)": names and types, in this order.
CONTRACT = """condition_id TEXT, enhancer TEXT, noise TEXT, snr_in_db REAL, rt60_s REAL,
speech_az_deg REAL, noise_az_deg REAL, seed INTEGER, snr_out_db REAL, snr_i_db REAL,
pesq_nb_in REAL, pesq_nb_out REAL, pesq_wb_in REAL, pesq_wb_out REAL, stoi_in REAL,
stoi_out REAL, speech_source TEXT, noise_source TEXT, status TEXT, error TEXT"""


def _row(cid="c1", enh="eb", **kw):
    row = {"condition_id": cid, "enhancer": enh, "noise": "babble", "snr_in_db": 0.0, "seed": 0, "status": "ok"}
    row.update(kw)
    return row


def test_schema_has_the_contract_columns_with_their_types(tmp_path):
    with ResultStore.open(tmp_path):
        pass
    db = sqlite3.connect(tmp_path / "results.sqlite")
    info = {r[1]: r[2] for r in db.execute("PRAGMA table_info(results)")}
    want = [tuple(item.split()) for item in CONTRACT.replace("\n", " ").split(", ")]
    for name, typ in want:
        assert info[name] == typ, name
    assert [n for n, _ in CONTRACT_COLUMNS] == [n for n, _ in want]
    # the unique index on (condition_id, enhancer)
    indexes = [r[1] for r in db.execute("PRAGMA index_list(results)") if r[2]]
    cols = [[c[2] for c in db.execute(f"PRAGMA index_info('{i}')")] for i in indexes]
    assert ["condition_id", "enhancer"] in cols


def test_every_evaluate_column_is_stored():
    """evaluate_enhancer's row keys all have a column (nothing silently dropped)."""
    missing = set(evaluate.ROW_COLUMNS) - set(COLUMNS)
    assert not missing


def test_wal_mode_and_synchronous_normal(tmp_path):
    with ResultStore.open(tmp_path) as store:
        assert store.journal_mode == "wal"
        assert store._db.execute("PRAGMA synchronous").fetchone()[0] == 1  # NORMAL


def test_upsert_replaces_never_duplicates(tmp_path):
    with ResultStore.open(tmp_path) as store:
        store.write_rows([_row(snr_out_db=1.0), _row(enh="ss", snr_out_db=2.0)])
        store.write_rows([_row(snr_out_db=5.0, status="error", error="boom")])
        rows = store.rows()
        assert store.count() == 2
        eb = next(r for r in rows if r["enhancer"] == "eb")
        assert eb["snr_out_db"] == 5.0 and eb["status"] == "error" and eb["error"] == "boom"


def test_unique_constraint_holds_against_plain_insert(tmp_path):
    with ResultStore.open(tmp_path) as store:
        store.write_rows([_row()])
    db = sqlite3.connect(tmp_path / "results.sqlite")
    with pytest.raises(sqlite3.IntegrityError):
        db.execute("INSERT INTO results (condition_id, enhancer, status) VALUES ('c1', 'eb', 'ok')")


def test_unknown_keys_ignored_missing_are_null_numpy_converted(tmp_path):
    with ResultStore.open(tmp_path) as store:
        store.write_rows([_row(not_a_column=3, snr_out_db=np.float64(4.5), seed=np.int64(7), snr_i_db=float("nan"))])
        (row,) = store.rows()
    assert "not_a_column" not in row
    assert row["snr_out_db"] == 4.5 and isinstance(row["snr_out_db"], float)
    assert row["seed"] == 7 and row["pesq_nb_out"] is None and row["snr_i_db"] is None
    assert row["created_at"]  # filled by the store


def test_done_keys_with_and_without_errors(tmp_path):
    with ResultStore.open(tmp_path) as store:
        store.write_rows([_row("a", "eb"), _row("a", "ss", status="error", error="x"), _row("b", "eb")])
        assert store.done_keys() == {("a", "eb"), ("a", "ss"), ("b", "eb")}
        assert store.done_keys(include_errors=False) == {("a", "eb"), ("b", "eb")}


def test_rows_survive_reopen_and_runs_are_recorded(tmp_path):
    with ResultStore.open(tmp_path) as store:
        run = store.start_run(
            sweep="smoke", source="smoke", config_toml="[sweep]\n", options={"limit": None},
            executor="local", workers=2, scheduler=None, data_dir=None,
        )
        store.write_rows([_row(run_id=run)])
        store.finish_run(run, status="finished", n_rows_written=1, n_errors=0)
    with ResultStore.open(tmp_path, readonly=True) as store:
        (runrow,) = store.runs()
        assert runrow["status"] == "finished" and runrow["config_toml"] == "[sweep]\n"
        assert '"numpy"' in runrow["versions_json"] and '"pesq"' in runrow["versions_json"]
        assert runrow["started_at"] <= runrow["finished_at"]
        assert store.rows()[0]["run_id"] == run


def test_readonly_open_of_a_missing_store_is_a_data_error(tmp_path):
    with pytest.raises(DataError, match="no results store"):
        ResultStore.open(tmp_path / "nowhere", readonly=True)
