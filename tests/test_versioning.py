"""A store never mixes sweep versions silently (issue 8, section 4).

Real SQLite stores, real runs of a tiny sweep (passthrough only, 1 s of audio, one worker).
"""

from __future__ import annotations

import sqlite3

import pytest

from benchmarks.cli.main import main
from benchmarks.report.from_store import write_store_report
from benchmarks.run.runner import run_sweep
from benchmarks.run.sweep import parse_sweep
from benchmarks.run.versioning import (
    SweepVersionError,
    config_version,
    describe_changes,
    sweep_config,
)

TOML = """
[sweep]
name = "tiny"
[axes]
enhancers = ["passthrough"]
noise = ["white"]
snr_db = [0, 10]
seeds = [0]
[fixed]
duration_s = {duration}
"""


def _sweep(duration=1.0, extra=""):
    return parse_sweep(TOML.format(duration=duration) + extra, source="tiny.toml")


def _run(sweep, out, **kw):
    return run_sweep(sweep, out, workers=1, report=False, progress=False, **kw)


def _count(out, table="results"):
    with sqlite3.connect(out / "results.sqlite") as db:
        return db.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0]


def test_rerunning_the_same_sweep_resumes(tmp_path):
    first = _run(_sweep(), tmp_path, limit=1)
    again = _run(_sweep(), tmp_path)  # a larger --limit is how a sweep resumes
    assert (first.n_computed, again.n_computed, again.n_skipped) == (1, 1, 1)
    more_seeds = _run(_sweep(), tmp_path, seed=3)  # --seed adds samples of the same sweep
    assert more_seeds.n_computed == 2 and _count(tmp_path) == 4


def test_a_changed_sweep_is_refused_with_what_changed(tmp_path):
    _run(_sweep(), tmp_path)
    with pytest.raises(SweepVersionError, match=r"duration_s 1\.0 -> 2\.0.*--new-version"):
        _run(_sweep(duration=2.0), tmp_path)
    with pytest.raises(SweepVersionError, match=r"snr_mode"):
        _run(_sweep(extra='snr_mode = "active"\n'), tmp_path)
    assert _count(tmp_path) == 2  # nothing written by the refused runs


def test_new_version_moves_the_old_rows_aside(tmp_path):
    _run(_sweep(), tmp_path)
    _run(_sweep(duration=2.0), tmp_path, new_version=True)
    assert _count(tmp_path) == 2 and _count(tmp_path, "results_previous") == 2
    with sqlite3.connect(tmp_path / "results.sqlite") as db:
        versions = {r[0] for r in db.execute("SELECT sweep_version FROM results")}
        old = {r[0] for r in db.execute("SELECT sweep_version FROM results_previous")}
    assert versions == {config_version(sweep_config(_sweep(duration=2.0)))}
    assert old == {config_version(sweep_config(_sweep()))} and old != versions


def test_changed_enhancer_params_count_as_a_new_version():
    base = sweep_config(parse_sweep(TOML.format(duration=1.0).replace('"passthrough"', '"ss"')))
    tuned = sweep_config(
        parse_sweep(TOML.format(duration=1.0).replace('"passthrough"', '"ss"') + "[enhancer_params.ss]\nalpha = 0.95\n")
    )
    assert config_version(base) != config_version(tuned)
    assert "enhancer_params.ss" in describe_changes(base, tuned)


def test_the_report_never_averages_two_versions(tmp_path):
    _run(_sweep(), tmp_path)
    with sqlite3.connect(tmp_path / "results.sqlite") as db:  # a row of another version slipped in
        db.execute("UPDATE results SET sweep_version = 'other' WHERE snr_in_db = 10")
    write_store_report(tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "1 rows of other versions not shown" in text
    assert "rows**: 1 (1 ok" in text


def test_cli_refusal_is_one_line_with_exit_code_2(tmp_path, capsys):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(TOML.format(duration=1.0))
    out = tmp_path / "out"
    assert main(["bench", "run", str(sweep_file), "--out", str(out), "--workers", "1", "--no-report"]) == 0
    sweep_file.write_text(TOML.format(duration=1.5))
    capsys.readouterr()
    assert main(["bench", "run", str(sweep_file), "--out", str(out), "--workers", "1", "--no-report"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "duration_s 1.0 -> 1.5" in err[0] and "new --out" in err[0]


def test_a_changed_column_definition_changes_every_version_and_the_report_says_so(tmp_path):
    """A store whose rows were computed under G.160 definition 1 (its config has no
    ``definitions``: written before issue 32) is refused by the same sweep now, naming the
    definition; its report says which definition its rows follow."""
    import json

    _run(_sweep(), tmp_path)
    write_store_report(tmp_path)
    assert "g160 v2" in (tmp_path / "report" / "summary.md").read_text()
    old = {k: v for k, v in sweep_config(_sweep()).items() if k != "definitions"}
    with sqlite3.connect(tmp_path / "results.sqlite") as db:
        db.execute("UPDATE meta SET value = ? WHERE key = 'sweep_config'", (json.dumps(old, sort_keys=True),))
        db.execute("UPDATE meta SET value = ? WHERE key = 'sweep_version'", (config_version(old),))
        db.execute("UPDATE results SET sweep_version = ?", (config_version(old),))
    db.close()
    write_store_report(tmp_path)
    assert "g160 v1 (rows from before issue 32)" in (tmp_path / "report" / "summary.md").read_text()
    with pytest.raises(SweepVersionError, match=r"definitions .* -> \{\"g160\": 2\}"):
        _run(_sweep(), tmp_path)


def test_a_store_of_one_row_is_guarded_like_any_other(tmp_path):
    # The smallest store: one row of the 1 s sweep.  A 2 s sweep into it is refused, and the row
    # is untouched (count 1, still the 1 s version's).
    first = _run(_sweep(), tmp_path, limit=1)
    assert first.n_computed == 1 and _count(tmp_path) == 1
    with pytest.raises(SweepVersionError, match=r"holds 1 rows .*duration_s 1\.0 -> 2\.0"):
        _run(_sweep(duration=2.0), tmp_path)
    assert _count(tmp_path) == 1
    with sqlite3.connect(tmp_path / "results.sqlite") as db:
        stored = db.execute("SELECT DISTINCT sweep_version FROM results").fetchall()
    assert stored == [(config_version(sweep_config(_sweep())),)]
