"""Rankings that follow the tests (issue 32 part 3): Holm-corrected paired tests, compact letters
that never join two systems the test separates, the sweep's ranking key, and the banner of a
limited or stopped run (part 4)."""

from __future__ import annotations

import csv
import sqlite3

import numpy as np
import pytest
from scipy import stats

from benchmarks.report.core import write_report
from benchmarks.report.from_store import write_store_report
from benchmarks.report.ranking import letters, pairwise_tests, rank_groups
from benchmarks.report.verdicts import paired_verdicts
from benchmarks.run.sweep import parse_sweep
from benchmarks.run.versioning import config_version, sweep_config
from scenesim.errors import ConfigError


def _rows(effects: dict[str, float], *, n_seeds=6, seed_spread=1.0, noise_sd=0.05, rng_seed=3):
    """Two conditions per seed; a large per-seed offset shared by every system (the marginal
    intervals overlap) and small independent noise (the paired differences are tight)."""
    rng = np.random.default_rng(rng_seed)
    rows = []
    for seed in range(n_seeds):
        offset = seed_spread * rng.standard_normal()
        for c in range(2):
            for name, eff in effects.items():
                rows.append(dict(condition_id=f"s{seed}c{c}", seed=seed, noise="babble", enhancer=name, status="ok",
                                 pesq_wb_out=2.0 + offset + eff + noise_sd * rng.standard_normal()))  # fmt: skip
    return rows


def _shares(a: str, b: str) -> bool:
    return bool(set(a) & set(b))


def test_a_system_that_beats_another_significantly_never_shares_its_group(tmp_path):
    """The issue's case: seed-to-seed spread makes the marginal intervals overlap (the old rule
    tied them), while the paired difference of +0.3 is resolved; A and B must not share a letter
    in ranking.csv, and the verdict against passthrough says the same."""
    rows = _rows({"passthrough": 0.0, "sysa": 0.3, "sysb": 0.0})
    per = {n: [np.mean([r["pesq_wb_out"] for r in rows if r["enhancer"] == n and r["seed"] == s]) for s in range(6)]
           for n in ("sysa", "sysb")}  # fmt: skip
    ci_a = stats.t.interval(0.95, 5, np.mean(per["sysa"]), stats.sem(per["sysa"]))
    ci_b = stats.t.interval(0.95, 5, np.mean(per["sysb"]), stats.sem(per["sysb"]))
    assert ci_a[0] < ci_b[1]  # the marginal intervals overlap: an interval rule would tie them
    write_report(rows, tmp_path)
    with open(tmp_path / "report" / "ranking.csv") as fh:
        tier = {r["enhancer"]: r["tier"] for r in csv.DictReader(fh)}
    assert not _shares(tier["sysa"], tier["sysb"]), tier
    assert _shares(tier["sysb"], tier["passthrough"]), tier  # identical systems are not separated
    verdict = next(r for r in paired_verdicts(rows, ("pesq_wb_out",)) if r["system"] == "sysa" and r["baseline"] == "passthrough")
    assert verdict["verdict"] == "better"


def test_p_values_are_scipy_paired_t_with_holm():
    """Oracle: scipy.stats.ttest_rel on the per-seed means, and Holm's step-down written out
    here (p_(i) * (m - i + 1), running maximum, capped at 1); tolerance 1e-12."""
    rows = _rows({"x": 0.0, "y": 0.05, "z": 0.2}, noise_sd=0.1)
    tests = pairwise_tests(rows, ["z", "y", "x"], "pesq_wb_out")
    seeds = range(6)
    mean = {n: [np.mean([r["pesq_wb_out"] for r in rows if r["enhancer"] == n and r["seed"] == s]) for s in seeds]
            for n in "xyz"}  # fmt: skip
    raw = [stats.ttest_rel(mean[t["system_a"]], mean[t["system_b"]]).pvalue for t in tests]
    np.testing.assert_allclose([t["p"] for t in tests], raw, rtol=0, atol=1e-12)
    order = np.argsort(raw)
    holm, running = np.empty(len(raw)), 0.0
    for i, k in enumerate(order):
        running = max(running, min(1.0, raw[k] * (len(raw) - i)))
        holm[k] = running
    np.testing.assert_allclose([t["p_holm"] for t in tests], holm, rtol=0, atol=1e-12)
    assert [t["separated"] for t in tests] == [bool(p < 0.05) for p in holm]


@pytest.mark.parametrize("rng_seed", range(6))
def test_letters_share_exactly_when_the_test_does_not_separate(rng_seed):
    """On random effects (5 systems, some close, some apart): for every pair, a shared letter
    <=> not separated by the Holm-corrected test (the compact letter display's defining property)."""
    rng = np.random.default_rng(rng_seed)
    effects = {f"s{i}": float(e) for i, e in enumerate(rng.choice([0.0, 0.04, 0.08, 0.3], size=5))}
    rows = _rows(effects, noise_sd=0.05, rng_seed=rng_seed)
    recs = rank_groups(rows, ("pesq_wb_out",))
    tier = {r["enhancer"]: r["tier"] for r in recs}
    tests = [t for t in recs[0]["tests"] if t["metric"] == "pesq_wb_out"]
    assert len(tests) == 10
    for t in tests:
        assert _shares(tier[t["system_a"]], tier[t["system_b"]]) == (not t["separated"]), (t, tier)
    # ordered by the mean, and the best system holds letter "a"
    means = [r["pesq_wb_out"] for r in recs]
    assert means == sorted(means, reverse=True) and "a" in recs[0]["tier"]


def test_non_transitive_tests_give_overlapping_letters():
    """A ~ B, B ~ C, A != C (p-values given): B carries both letters."""
    tests = [dict(system_a="A", system_b="B", p_holm=0.5), dict(system_a="B", system_b="C", p_holm=0.5),
             dict(system_a="A", system_b="C", p_holm=0.001)]  # fmt: skip
    got = letters(["A", "B", "C"], tests)
    assert got == {"A": "a", "B": "ab", "C": "b"}


def test_one_seed_separates_nothing():
    rows = _rows({"a": 0.0, "b": 1.0}, n_seeds=1)
    recs = rank_groups(rows, ("pesq_wb_out",))
    assert [r["enhancer"] for r in recs] == ["b", "a"] and {r["tier"] for r in recs} == {"a"}


_TOML = """
[sweep]
name = "t"
ranking = {ranking}

[axes]
enhancers = ["passthrough", "ss"]
noise = ["babble"]
snr_db = [0]
"""


def test_sweep_ranking_key_is_validated_and_not_part_of_the_version():
    sweep = parse_sweep(_TOML.format(ranking='["estoi_out", "pesq_wb_out"]'), source="t.toml")
    assert sweep.ranking == ("estoi_out", "pesq_wb_out")
    other = parse_sweep(_TOML.format(ranking='["si_sdr_out_db"]'), source="t.toml")
    assert config_version(sweep_config(sweep)) == config_version(sweep_config(other))
    with pytest.raises(ConfigError, match=r"t\.toml: line 4: key 'sweep\.ranking': expected a non-empty list .*'bogus'"):
        parse_sweep(_TOML.format(ranking='["pesq_wb_out", "bogus"]'), source="t.toml")
    with pytest.raises(ConfigError, match=r"key 'sweep\.ranking'"):
        parse_sweep(_TOML.format(ranking='"pesq_wb_out"'), source="t.toml")
    with pytest.raises(ConfigError, match=r"key 'sweep\.ranking'"):
        parse_sweep(_TOML.format(ranking='["estoi_out", "estoi_out"]'), source="t.toml")


def test_limited_and_stopped_runs_are_named_on_the_page(tmp_path):
    """``--limit 2`` of smoke's 4 conditions: the banner says "2 of 4 conditions"; a run marked
    interrupted has its rows named; and the sweep's ranking key reaches the report."""
    from benchmarks.cli.main import main
    from benchmarks.run.sweep import load_sweep

    toml = tmp_path / "s.toml"
    text = load_sweep("smoke").text.replace('[sweep]\n', '[sweep]\nranking = ["stoi_out"]\n', 1)
    toml.write_text(text)
    out = tmp_path / "out"
    assert main(["bench", "run", str(toml), "--limit", "2", "--workers", "1", "--no-report", "--out", str(out)]) == 0
    write_store_report(out)
    summary = (out / "report" / "summary.md").read_text()
    assert "Partial run: 2 of 4 conditions" in summary and "--limit 2" in summary
    assert "ordered by STOI (the sweep's `ranking` key)" in summary
    db = sqlite3.connect(out / "results.sqlite")
    with db:
        db.execute("UPDATE runs SET status = 'interrupted'")
        n_rows = db.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    db.close()
    write_store_report(out)
    summary = (out / "report" / "summary.md").read_text()
    assert f"{n_rows} of these rows were written by run" in summary and "ended interrupted" in summary
