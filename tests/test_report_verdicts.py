"""Statistics that decide (issue 16 part 4) and the workflows that feed them (issue 20 part 5):
paired verdicts against scipy's paired t-test, verdicts per RT60, honest small-n cells,
``--seeds`` and the stratified ``--limit`` (the ranking: tests/test_report_ranking.py)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy import stats

from benchmarks.report.core import write_report
from benchmarks.report.html import markdown_to_html
from benchmarks.report.ranking import ranking_section
from benchmarks.report.tables import MIN_T_SEEDS, aggregate, metric_range, stat_cell
from benchmarks.report.verdicts import diff_cell, paired_verdicts
from benchmarks.run.sweep import load_sweep, stratified


def _rows(n_seeds=6, *, gain=1.5, spread=1.0):
    """Two systems and two baselines on babble at 0 and 10 dB; per seed, eb's SNR-I exceeds
    passthrough's by ``gain`` plus a seed-dependent term (the paired differences vary)."""
    rng = np.random.default_rng(7)
    rows = []
    for seed in range(n_seeds):
        jitter = rng.normal(0.0, spread, size=2)
        for k, snr in enumerate((0.0, 10.0)):
            base = 0.3 * seed + snr / 10
            for name, v in (("passthrough", 0.0), ("ss", 1.0), ("eb", gain + jitter[k])):
                rows.append(dict(condition_id=f"c{seed}-{snr}", seed=seed, noise="babble", snr_in_db=snr,
                                 enhancer=name, snr_i_db=base + v, pesq_nb_raw_out=2.0 + 0.1 * v,
                                 stoi_out=0.8 + 0.01 * v, status="ok"))  # fmt: skip
    return rows


def test_paired_interval_equals_scipy_ttest_rel():
    # Oracle: scipy.stats.ttest_rel on the per-seed means (each seed's mean over its two
    # conditions), confidence_interval(0.95); tolerance 1e-12 (same formula, float rounding).
    rows = _rows()
    rec = next(r for r in paired_verdicts(rows, ("snr_i_db",)) if (r["system"], r["baseline"]) == ("eb", "passthrough"))
    per_seed = {}
    for r in rows:
        per_seed.setdefault((r["seed"], r["enhancer"]), []).append(r["snr_i_db"])
    x = [np.mean(per_seed[(s, "eb")]) for s in range(6)]
    y = [np.mean(per_seed[(s, "passthrough")]) for s in range(6)]
    ci = stats.ttest_rel(x, y).confidence_interval(0.95)
    assert rec["n"] == 6
    np.testing.assert_allclose([rec["ci_low"], rec["ci_high"]], [ci.low, ci.high], rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec["mean_diff"], np.mean(np.subtract(x, y)), atol=1e-12)
    assert rec["verdict"] == ("better" if ci.low > 0 else "worse" if ci.high < 0 else "not resolved")


@pytest.mark.parametrize(("gain", "expected"), [(3.0, "better"), (-3.0, "worse"), (0.0, "not resolved")])
def test_verdicts_follow_the_interval(gain, expected):
    recs = paired_verdicts(_rows(gain=gain, spread=0.3), ("snr_i_db",))
    rec = next(r for r in recs if (r["system"], r["baseline"]) == ("eb", "passthrough"))
    assert rec["verdict"] == expected
    assert {r["baseline"] for r in recs} == {"passthrough", "ss"}


def test_one_seed_is_never_resolved_and_small_n_shows_the_seeds():
    rec = next(r for r in paired_verdicts(_rows(1), ("snr_i_db",)) if r["system"] == "eb")
    assert rec["n"] == 1 and rec["ci_low"] is None and rec["verdict"] == "not resolved"
    rec = next(r for r in paired_verdicts(_rows(3), ("snr_i_db",)) if r["system"] == "eb")
    cell = diff_cell(rec)
    assert "(seeds " in cell and "[" not in cell  # n = 3 < 5: min … max, no t-interval


def test_cells_never_print_an_interval_wider_than_the_metric_range():
    # Oracle: PESQ raw lies in [-0.5, 4.5]; two seeds 0.5 and 4.0 give a t-interval of
    # 2.25 ± 22.2 -- the cell shows the seeds' min and max instead.
    vals = [{"pesq_nb_raw_out": v} for v in (0.5, 4.0)]
    rec = aggregate(vals, (), ("pesq_nb_raw_out",))[0]
    assert rec["pesq_nb_raw_out_ci95"] > 20
    assert stat_cell(rec, "pesq_nb_raw_out") == "2.25 (0.50 … 4.00)"
    vals = [{"stoi_out": v} for v in (0.99, 0.2, 0.99, 0.99, 0.99)]
    rec = aggregate(vals, (), ("stoi_out",))[0]
    cell = stat_cell(rec, "stoi_out")
    lo, hi = (float(x) for x in re.findall(r"\[(.*), (.*)\]", cell)[0])
    assert cell.endswith("]*") and (lo, hi) != (0.0, 1.0) and lo >= metric_range("stoi_out")[0] and hi == 1.0


def test_verdicts_are_per_rt60_never_pooled():
    """Two RT60s where eb beats passthrough by +3 at one and loses by 3 at the other: pooled, the
    difference would be 0; per RT60 each verdict is resolved (oracle: the constructed gains)."""
    rows = []
    for rt, gain in ((0.3, 3.0), (0.6, -3.0)):
        for r in _rows(gain=gain, spread=0.3):
            rows.append({**r, "rt60_s": rt, "condition_id": f"{r['condition_id']}-{rt}"})
    recs = [r for r in paired_verdicts(rows, ("snr_i_db",)) if (r["system"], r["baseline"]) == ("eb", "passthrough")]
    assert {r["noise"]: r["verdict"] for r in recs} == {"babble, RT60 0.3 s": "better", "babble, RT60 0.6 s": "worse"}


def test_ranking_shows_dnsmos_only_when_the_rows_have_it(tmp_path):
    """DNSMOS OVRL (``metrics = ["dnsmos"]``) joins the default rule's columns when the rows hold
    it, as the seeds' mean (min … max) -- oracle: numpy over the per-seed means -- with its own
    letters and in ranking.csv; absent, it adds no column."""
    rows = [dict(r, pesq_wb_out=r["pesq_nb_raw_out"]) for r in _rows(n_seeds=3)]
    lines, _ = ranking_section(rows, tmp_path)
    assert not any("DNSMOS" in line for line in lines)
    for r in rows:
        r["dnsmos_ovrl"] = {"passthrough": 3.5, "ss": 2.0, "eb": 1.0}[r["enhancer"]] + 0.1 * r["seed"]
    text = "\n".join(ranking_section(rows, tmp_path)[0])
    head = next(line for line in text.splitlines() if line.startswith("| rank"))
    assert head.endswith("| DNSMOS OVRL | n seeds |") and "DNSMOS SIG" not in head
    eb = next(line for line in text.splitlines() if "| `eb` |" in line)
    assert eb.split(" | ")[-2].startswith(f"{np.mean([1.0, 1.1, 1.2]):.2f} (1.00 … 1.20) **")
    assert "letters_dnsmos_ovrl" in (tmp_path / "ranking.csv").read_text().splitlines()[0]


def test_report_has_contents_verdicts_and_resolving_links(tmp_path):
    write_report([dict(r, pesq_wb_out=r["pesq_nb_raw_out"]) for r in _rows()], tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert text.index("## Contents") < text.index("## Ranking") < text.index("## Paired verdicts") < text.index("## Overview")
    assert "the field's metrics" in text and f"n ≥ {MIN_T_SEEDS}" in text
    page = markdown_to_html(text)
    links = re.findall(r'href="#([\w-]+)"', page)
    ids = set(re.findall(r' id="([\w-]+)"', page))
    assert links and set(links) <= ids


def test_seeds_option_replaces_the_seed_list():
    preset = load_sweep("phone")
    sweep = preset.with_seeds(2)
    assert sorted({c.seed for c in sweep.conditions()}) == [0, 1]
    per_seed = preset.n_conditions // len({c.seed for c in preset.conditions()})
    assert len({c.seed for c in preset.conditions()}) == 5 and sweep.n_conditions == per_seed * 2


@pytest.mark.parametrize("preset", ["peers", "reverb", "phone"])
def test_limit_is_stratified_over_every_swept_axis(preset):
    sweep = load_sweep(preset).with_seeds(2)
    n = max(len(sweep.axes[a]) for a in sweep.swept_axes)
    picked = stratified(sweep.conditions(), n, sweep.swept_axes)
    assert len(picked) == n and picked[0] == sweep.conditions()[0]
    for axis in sweep.swept_axes:
        counts = {v: sum(getattr(c, axis) == v for c in picked) for v in sweep.axes[axis]}
        assert max(counts.values()) - min(counts.values()) <= 1, (axis, counts)  # balanced marginals


def test_bench_run_seeds_and_limit_from_the_command_line(tmp_path):
    """``--seeds 3 --limit 3`` on smoke (2 noises x 2 SNRs): three conditions, three seeds, both
    noises and both SNRs -- the seed list is replaced without editing TOML."""
    from benchmarks.cli.main import main
    from benchmarks.store.sqlite import ResultStore

    out = tmp_path / "s"
    argv = ["bench", "run", "smoke", "--seeds", "3", "--limit", "3", "--workers", "1", "--no-report", "--out", str(out)]
    assert main(argv) == 0
    with ResultStore.open(out, readonly=True) as store:
        rows = store.rows()
    assert len({r["condition_id"] for r in rows}) == 3
    assert sorted({r["seed"] for r in rows}) == [0, 1, 2]
    assert {r["noise"] for r in rows} == {"babble", "wind"} and {r["snr_in_db"] for r in rows} == {0.0, 10.0}
