"""A report says on top when a tuned system is evaluated on the material it was tuned on (issue 30 part 2).

Oracle: the sweeps' own construction.  The toy ``toy-peak`` (tests/test_tune.py) is tuned by
``scenesim tune`` on split ``dev``, seed 0, the built-in data; its parameter set is then run
through a sweep's ``[parameter_sets]`` (or ``register_tuned``) by the project's runner into real
SQLite stores.  A ``dev`` sweep on seeds 0 and 1 uses the tuning split in both rows, the tuning
seed in one, and the tuning draw's very generator seeds (``dev_files``) in that one only (the
built-in data draws every seed of a split from its own generator seed); a ``test`` sweep on
seeds 1 and 2 shares none of it.  Conditions are 2 s, one noise, one SNR: the whole module runs
in about 10 s.
"""

from __future__ import annotations

import csv
import json
import sqlite3

import pytest

pytest.importorskip("optuna")

from test_tune import Peak  # noqa: E402

from benchmarks.cli.main import main  # noqa: E402
from benchmarks.tune import register_tuned  # noqa: E402
from benchmarks.tune.overlap import count_overlap  # noqa: E402
from enhancers.core.registry import register, unregister  # noqa: E402

SWEEP = """
[sweep]
name = "overlap"
split = "{split}"
[axes]
enhancers = {enhancers}
noise = ["wind"]
snr_db = [10]
seeds = {seeds}
[fixed]
fs = 16000
duration_s = 2.0
rt60_s = 0.0
speech_az_deg = 45
noise_az_deg = 270
noise_field = "point"
far_field = true
{extra}"""

SYSTEM = "toy-peak-tuned"


@pytest.fixture(autouse=True)
def toy_peak():
    register("toy-peak", Peak)
    yield
    for name in ("toy-peak", "toy-peak-reg"):
        try:
            unregister(name)
        except KeyError:
            pass


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    """``scenesim tune`` on dev seed 0 (two trials, then its one test run): the params.toml."""
    root = tmp_path_factory.mktemp("tuned")
    (root / "dev.toml").write_text(SWEEP.format(split="dev", enhancers='["passthrough"]', seeds="[0]", extra=""))
    register("toy-peak", Peak)
    try:
        assert main(["tune", "toy-peak", "--sweep", str(root / "dev.toml"), "--param", "p=0:1", "--objective",
                     "mean:snr_i_db", "--trials", "2", "--out", str(root / "t"), "--workers", "1"]) == 0
    finally:
        unregister("toy-peak")
    return root / "t"


def _run(tmp_path, tuned, *, split, seeds, system=SYSTEM, parameter_sets=True):
    extra = f'[parameter_sets]\n{system} = "{tuned / "params.toml"}"\n' if parameter_sets else ""
    sweep = tmp_path / f"{split}.toml"
    sweep.write_text(SWEEP.format(split=split, enhancers=f'["passthrough", "{system}"]', seeds=seeds, extra=extra))
    out = tmp_path / "o"
    assert main(["bench", "run", str(sweep), "--out", str(out), "--workers", "1"]) == 0
    return out


def _banner(out) -> list[str]:
    return [ln for ln in (out / "report" / "summary.md").read_text().splitlines() if "In-sample rows" in ln]


def _csv(out) -> list[dict]:
    with open(out / "report" / "in_sample.csv", newline="") as f:
        return list(csv.DictReader(f))


def test_the_tuning_run_records_its_material(tuned):
    """The parameter set names what the search drew (the built-in dev generator seed of seed 0),
    and the tuner's own test run (test split, seed 1) shares none of it: no banner there."""
    from benchmarks.tune import load_parameter_set

    prov = load_parameter_set(tuned / "params.toml").provenance
    assert prov["split"] == "dev" and prov["seeds"] == [0] and prov["test_seeds"] == [1]
    assert prov["dev_files"] and all(f.endswith(f"seed={2**64}") for f in prov["dev_files"])
    assert "In-sample" not in (tuned / "tune_report.md").read_text()


def test_rows_on_the_tuning_split_get_a_banner_naming_the_system_and_the_count(tmp_path, tuned):
    out = _run(tmp_path, tuned, split="dev", seeds="[0, 1]")
    (line,) = _banner(out)
    assert f"system {SYSTEM} was tuned on split dev, seeds 0, data built-in" in line
    assert ("2 of 2 of its rows here use that material (2 on its tuning split, 1 on its tuning seeds, "
            "1 sharing speech or noise files with it)") in line and "in-sample" in line
    assert "passthrough" not in line
    summary = (out / "report" / "summary.md").read_text()
    assert summary.index("In-sample rows") < summary.index("## Contents")  # on top, like the partial-run banner
    assert "In-sample rows" in (out / "report" / "index.html").read_text()
    (rec,) = _csv(out)
    assert (rec["system"], rec["rows"], rec["in_sample_rows"], rec["on_tuning_seeds"], rec["sharing_files"]) == \
        (SYSTEM, "2", "2", "1", "1")


def test_a_registered_tuned_set_is_recorded_too(tmp_path, tuned):
    register_tuned("toy-peak-reg", tuned / "params.toml")
    out = _run(tmp_path, tuned, split="dev", seeds="[0]", system="toy-peak-reg", parameter_sets=False)
    (line,) = _banner(out)
    assert "system toy-peak-reg was tuned on split dev" in line and "1 of 1 of its rows" in line


def test_test_split_rows_on_other_seeds_get_no_banner(tmp_path, tuned):
    out = _run(tmp_path, tuned, split="test", seeds="[1, 2]")
    assert _banner(out) == []
    (rec,) = _csv(out)
    assert (rec["system"], rec["rows"], rec["in_sample_rows"]) == (SYSTEM, "2", "0")


def test_the_listening_page_rebuilds_a_parameter_set_system(tmp_path, tuned):
    """The report's re-render builds a ``[parameter_sets]`` system from its base enhancer and the set's
    parameters (its sweep name is not registered): the same spec as stored, so it is played."""
    from benchmarks.report import listening
    from benchmarks.store.frame import load_results
    from benchmarks.store.sqlite import ResultStore

    out = _run(tmp_path, tuned, split="test", seeds="[1]")
    with ResultStore(out / "results.sqlite", readonly=True) as store:
        params, bases = listening._sweep_params(store.runs())
    assert bases == {SYSTEM: "toy-peak"}
    rows = {r["enhancer"]: r for r in load_results(out, ok_only=True).to_dict("records")}
    signals, _, notes = listening.render_condition(rows, data_dir=None, params=params, bases=bases)
    assert SYSTEM in signals and not [n for n in notes if SYSTEM in n], notes


def test_an_old_store_without_provenance_loads_and_reports_without_the_banner(tmp_path, tuned):
    """The same rows as written before runs recorded provenance and rows their files."""
    out = _run(tmp_path, tuned, split="dev", seeds="[0, 1]")
    with sqlite3.connect(out / "results.sqlite") as db:
        for run_id, options in db.execute("SELECT run_id, options_json FROM runs").fetchall():
            old = {k: v for k, v in json.loads(options).items() if k != "tuned"}
            db.execute("UPDATE runs SET options_json = ? WHERE run_id = ?", (json.dumps(old), run_id))
        db.execute("UPDATE results SET speech_files = NULL, noise_files = NULL")
    (out / "report" / "in_sample.csv").unlink()
    assert main(["bench", "report", str(out)]) == 0
    assert _banner(out) == [] and not (out / "report" / "in_sample.csv").exists()


def test_tune_report_says_so_if_its_test_run_overlaps_dev(tmp_path, monkeypatch):
    """Were the test run ever drawn from the tuning material (here: forced to be the dev sweep),
    its report would open with the banner."""
    from benchmarks.tune import tuner

    monkeypatch.setattr(tuner, "test_sweep", lambda dev, seeds, n: dev)
    (tmp_path / "dev.toml").write_text(SWEEP.format(split="dev", enhancers='["passthrough"]', seeds="[0]", extra=""))
    assert main(["tune", "toy-peak", "--sweep", str(tmp_path / "dev.toml"), "--param", "p=0:1", "--objective",
                 "mean:snr_i_db", "--trials", "1", "--out", str(tmp_path / "t"), "--workers", "1"]) == 0
    first = (tmp_path / "t" / "tune_report.md").read_text().split("\n\n")[1]
    assert first.startswith("**⚠ In-sample rows: system toy-peak-tuned") and "1 of 1 of its rows" in first


@pytest.mark.parametrize(
    ("row", "expected"),
    [({"split": "dev", "seed": 0}, (1, 1, 1)), ({"split": "dev", "seed": 7}, (1, 1, 0)),
     ({"split": "all", "seed": 7}, (1, 1, 0)), ({"split": "test", "seed": 0}, (0, 0, 0)),
     ({"split": "dev", "seed": 0, "data": "/elsewhere"}, (0, 0, 0))],
)
def test_an_old_parameter_set_is_judged_by_split_seeds_and_data(row, expected):
    """Without ``dev_files``: in-sample on the tuning data's tuning split (or ``all``); the tuning
    seeds counted apart; other data or the test split are not."""
    prov = {"split": "dev", "seeds": [0, 1], "data": "built-in"}
    o = count_overlap("x", [row], prov, lambda r: r.get("data", "built-in"))
    assert (o.in_sample, o.on_split, o.on_seeds) == expected and o.sharing_files == 0


def test_files_overlap_by_segment_whatever_the_split():
    """A row on another split of another data directory still shares a file segment with the tuning draw."""
    prov = {"split": "dev", "seeds": [0], "data": "/a", "dev_files": ["/d/noise/n.wav[0:800]"]}
    rows = [{"split": "test", "seed": 5, "noise_files": json.dumps(["/d/noise/n.wav[700:1000]@3"])},
            {"split": "test", "seed": 5, "noise_files": json.dumps(["/d/noise/n.wav[800:1000]@3"])}]
    o = count_overlap("x", rows, prov, lambda r: "/b")
    assert (o.in_sample, o.sharing_files, o.on_split) == (1, 1, 0)


@pytest.mark.parametrize(
    ("table", "says"),
    [('passthrough = "{p}"', "a name of its own"), ('other = "{p}"', "not in axes.enhancers"),
     ('toy = "missing.toml"', "cannot read parameter set")],
)
def test_bad_parameter_sets_entry_is_one_line(tmp_path, tuned, capsys, table, says):
    enhancers = '["passthrough", "toy"]' if table.startswith("toy") else '["passthrough"]'
    extra = "[parameter_sets]\n" + table.format(p=tuned / "params.toml") + "\n"
    sweep = tmp_path / "bad.toml"
    sweep.write_text(SWEEP.format(split="dev", enhancers=enhancers, seeds="[0]", extra=extra))
    assert main(["bench", "run", str(sweep), "--out", str(tmp_path / "o"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "parameter_sets" in err and says in err, err
