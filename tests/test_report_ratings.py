"""The report's "Listening test" section (issue 35) on stores with synthetic ratings.

Oracles: closed forms (ratings = a x metric + b exactly: Pearson 1; a monotone non-linear map:
Spearman 1), scipy.stats as an outside implementation (pearsonr's Fisher-z interval, ttest_rel,
t.interval), a slow Holm written out here, and listeners built to fail the screening rules.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from benchmarks.report import ratings as R
from benchmarks.report.core import write_report
from benchmarks.store.sqlite import ResultStore

SYSTEMS = ("eb", "ss", "eb-ss")
CONDS = tuple(f"c{k}" for k in range(4))
TOL = 1e-12  # float64 arithmetic on a dozen numbers


def _metric(cid, system):
    """A metric value per clip, all distinct (12 clips)."""
    return 1.0 + 0.37 * CONDS.index(cid) + 1.1 * SYSTEMS.index(system)


def _rows():
    return [{"condition_id": c, "enhancer": s, "status": "ok", "noise": "babble", "snr_in_db": 0.0, "seed": 0,
             "pesq_wb_out": _metric(c, s), "estoi_out": math.exp(_metric(c, s)), "snr_i_db": _metric(c, s)}
            for c in CONDS for s in SYSTEMS]  # fmt: skip


def _mushra(listener, rating_of, reference=100.0):
    out = [{"listener": listener, "method": "mushra", "condition_id": c, "system": s, "scale": "mushra",
            "rating": rating_of(c, s)} for c in CONDS for s in SYSTEMS]  # fmt: skip
    out += [{"listener": listener, "method": "mushra", "condition_id": c, "system": "reference", "scale": "mushra",
             "rating": reference} for c in CONDS]  # fmt: skip
    return out


def _good_listeners(a=20.0, b=5.0):
    """Three listeners whose offsets (-3, 0, +3) cancel: the clip means are a x metric + b exactly."""
    return [r for k, off in enumerate((-3.0, 0.0, 3.0))
            for r in _mushra(f"l{k}", lambda c, s, off=off: a * _metric(c, s) + b + off)]  # fmt: skip


def _bad_listener():
    """Hidden reference at 50 in every trial (fails BS.1534's rule) and ratings against the metric."""
    return _mushra("bad", lambda c, s: 100.0 - 10.0 * _metric(c, s), reference=50.0)


def test_ratings_equal_to_a_linear_map_of_a_metric_have_pearson_one():
    agree = {(a["metric"], a["scale"]): a for a in R.metric_agreement(_good_listeners(), _rows())}
    pesq = agree[("pesq_wb_out", "mushra")]
    assert pesq["n"] == 12
    assert pesq["pearson"] == pytest.approx(1.0, abs=TOL) and pesq["spearman"] == pytest.approx(1.0, abs=TOL)
    # exp(metric) is monotone: rank order identical (Spearman 1), not linear (Pearson below 1, as scipy says)
    est = agree[("estoi_out", "mushra")]
    assert est["spearman"] == pytest.approx(1.0, abs=TOL)
    x = [math.exp(_metric(c, s)) for c in CONDS for s in SYSTEMS]
    y = [20.0 * _metric(c, s) + 5.0 for c in CONDS for s in SYSTEMS]
    assert est["pearson"] == pytest.approx(stats.pearsonr(x, y).statistic, abs=TOL) and est["pearson"] < 0.99
    ci = stats.pearsonr(x, y).confidence_interval(0.95)  # Fisher z in scipy too
    assert (est["pearson_low"], est["pearson_high"]) == pytest.approx((ci.low, ci.high), abs=1e-9)
    assert ("dnsmos_sig", "sig") not in agree  # no such column: no row


def test_screening_removes_the_listener_built_to_fail_it():
    ratings = _good_listeners() + _bad_listener()
    screen = {s["listener"]: s for s in R.screen_listeners(ratings)}
    assert screen["bad"]["excluded"] and screen["bad"]["failed"] == 4
    assert not any(screen[f"l{k}"]["excluded"] for k in range(3))
    kept = R.retained(ratings)
    assert {r["listener"] for r in kept} == {"l0", "l1", "l2"}
    pesq = next(a for a in R.metric_agreement(kept, _rows()) if a["metric"] == "pesq_wb_out")
    assert pesq["pearson"] == pytest.approx(1.0, abs=TOL)
    # the rule's edge: 1 failure in 7 trials (14 %) is kept, 2 in 7 (29 %) excluded
    edge = [{"listener": "e", "method": "mushra", "condition_id": f"d{k}", "system": "reference",
             "scale": "mushra", "rating": 89.0 if k < n else 95.0} for n in (1,) for k in range(7)]  # fmt: skip
    assert not R.screen_listeners(edge)[0]["excluded"]
    edge[1]["rating"] = 89.0
    assert R.screen_listeners(edge)[0]["excluded"]


def test_p835_screening_excludes_a_clean_background_rated_worse_than_the_mixture():
    def p835(listener, ref_bak, mix_bak):
        return [{"listener": listener, "method": "p835", "condition_id": c, "system": s, "scale": "bak", "rating": v}
                for c in CONDS for s, v in (("reference", ref_bak), ("mixture", mix_bak), ("eb", 3))]  # fmt: skip

    screen = {s["listener"]: s for s in R.screen_listeners(p835("ok", 5, 2) + p835("swapped", 1, 4))}
    assert not screen["ok"]["excluded"] and screen["swapped"]["excluded"] and screen["swapped"]["checked"] == 4


def test_means_and_paired_comparisons_against_scipy():
    rng = np.random.default_rng(3)
    ratings = [r for k in range(5) for r in _mushra(f"l{k}", lambda c, s: float(rng.integers(0, 101)))]
    means = {(m["system"], m["condition_id"]): m for m in R.rating_means(ratings)}
    vals = [r["rating"] for r in ratings if r["system"] == "ss" and r["condition_id"] == "c2"]
    lo, hi = stats.t.interval(0.95, len(vals) - 1, loc=np.mean(vals), scale=stats.sem(vals))
    m = means[("ss", "c2")]
    assert m["n"] == 5 and (m["mean"], m["ci_low"], m["ci_high"]) == pytest.approx((np.mean(vals), lo, hi), abs=1e-9)
    pairs = R.paired_comparisons(ratings)
    assert [(p["a"], p["b"]) for p in pairs] == [("eb", "eb-ss"), ("eb", "ss"), ("eb-ss", "ss")]  # no reference
    cell = {(r["listener"], r["condition_id"], r["system"]): r["rating"] for r in ratings}
    keys = sorted({(li, c) for li, c, _ in cell})
    want_p = [stats.ttest_rel([cell[(*k, b)] for k in keys], [cell[(*k, a)] for k in keys]).pvalue
              for a, b in (("eb", "eb-ss"), ("eb", "ss"), ("eb-ss", "ss"))]  # fmt: skip
    assert [p["p"] for p in pairs] == pytest.approx(want_p, abs=1e-12)
    assert [p["n"] for p in pairs] == [20, 20, 20]
    # Holm written out: the i-th smallest p times (m - i), made non-decreasing
    order = np.argsort(want_p)
    slow = np.maximum.accumulate([min(1.0, (3 - i) * want_p[j]) for i, j in enumerate(order)])
    assert [pairs[j]["p_holm"] for j in order] == pytest.approx(slow, abs=1e-11)


def test_a_shift_every_listener_hears_is_separated():
    ratings = [r for k in range(4) for r in _mushra(f"l{k}", lambda c, s, k=k: 40.0 + k + (25.0 if s == "eb-ss" else 0.0)
                                                   + CONDS.index(c) * (0.5 if s == "eb" else -0.5))]  # fmt: skip
    pairs = {(p["a"], p["b"]): p for p in R.paired_comparisons(ratings)}
    assert pairs[("eb", "eb-ss")]["separated"] and pairs[("eb-ss", "ss")]["separated"]
    assert pairs[("eb", "eb-ss")]["mean_diff"] == pytest.approx(25.0 - np.mean(range(4)), abs=TOL)  # eb-ss - eb = 25 - index


def test_the_report_shows_the_section_only_with_ratings(tmp_path):
    rows = _rows()
    with ResultStore.open(tmp_path) as store:
        store.write_rows(rows)
    write_report(rows, tmp_path, listen=None)
    assert "## Listening test" not in (tmp_path / "report" / "summary.md").read_text()
    with ResultStore.open(tmp_path) as store:
        for r in _good_listeners() + _bad_listener():
            store.write_rating(r)
    paths = write_report(rows, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "## Listening test" in text and "| mushra | bad | 4 of 4 | excluded |" in text
    assert "| PESQ-wb | mushra MUSHRA | 12 | 1.00 [1.00, 1.00] | 1.00 [1.00, 1.00] |" in text
    assert {p.name for p in paths} >= {"ratings_means.csv", "ratings_pairs.csv", "ratings_agreement.csv"}


def test_a_ratings_table_of_a_newer_layout_is_refused(tmp_path):
    from scenesim.errors import DataError

    with ResultStore.open(tmp_path) as store:
        store.set_meta("ratings_schema", "99")
    with pytest.raises(DataError, match="layout version 99, newer"):
        ResultStore.open(tmp_path)
