"""Rankings that follow the tests: pairwise paired t-tests, Holm's correction, compact letters.

Per stratum (a noise; a noise and an RT60 when the rows sweep RT60, :func:`strata`) every pair of
systems is compared by the same test the paired verdicts show
(:mod:`benchmarks.report.verdicts`): the difference on the conditions both systems have
(paired by ``condition_id``), averaged within each seed, then Student's paired t-test over the
seeds (``scipy.stats.ttest_rel``; a constant non-zero difference counts as separated, p = 0;
fewer than two seeds cannot separate, p = 1).  The ``k (k - 1) / 2`` p-values of a stratum are
adjusted by Holm's step-down method (Holm 1979, ``statsmodels``' ``multipletests``), and two
systems are *separated* when the adjusted p is below :data:`ALPHA`.  The groups are a
**compact letter display** (Piepho 2004, ``scikit_posthocs.compact_letter_display``): two
systems share a letter exactly when the test does not separate them.  Pairwise tests are not
transitive (A ~ B, B ~ C, A != C), so strict tiers cannot always exist; letters can say it
(A ``a``, B ``ab``, C ``b``).  ``ranking.csv`` keeps the letters in its ``tier`` column.

Why not a critical-difference diagram (Friedman + Nemenyi over conditions, Demsar 2006): it
ranks systems within each condition and tests mean ranks, a different question on a different
``n`` (conditions, not seeds) and a different statistic than the paired verdicts beside it,
so its groups could contradict the verdicts on the same page.  The letters come from the
verdicts' own test.

The rule (:data:`DEFAULT_RULE`, or a sweep's ``[sweep] ranking = [...]``) lists the metrics:
the first one the rows hold decides the letters; systems are ordered by the rule's metrics
in turn (means over seeds), so ``a`` goes to the best.  Every metric of the rule gets its
own letters in the headline table (:func:`headline_lines`, one "system x metric" table).

References: Holm, S. (1979), Scand. J. Statist. 6, 65-70; Piepho, H.-P. (2004), J. Comput.
Graph. Statist. 13(2), 456-466; Demsar, J. (2006), JMLR 7, 1-30.

>>> rows = [dict(condition_id=f"c{s}", seed=s, noise="w", enhancer=e, pesq_wb_out=v + 0.1 * s)
...         for s in range(5) for e, v in (("a", 2.0), ("b", 2.5), ("c", 2.5))]
>>> [(r["enhancer"], r["tier"]) for r in rank_groups(rows, ("pesq_wb_out",))]
[('b', 'a'), ('c', 'a'), ('a', 'b')]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.report.tables import (
    digits_for,
    fmt,
    markdown_table,
    num,
    seed_interval,
    seed_means,
    write_csv,
)
from benchmarks.report.verdicts import METRIC_LABELS, per_seed_pairs, strata
from benchmarks.run.sweep import DEFAULT_RANKING, RANKABLE_METRICS

#: Significance level of every test, after Holm's correction within a stratum.
ALPHA = 0.05
#: The field's metrics, the default rule (wide-band PESQ MOS-LQO, ESTOI, SI-SDR, DNSMOS OVRL where computed).
DEFAULT_RULE = DEFAULT_RANKING
#: Labels of the metrics a sweep's ``ranking`` key may name (:data:`~benchmarks.run.sweep.RANKABLE_METRICS`).
RANKABLE = {m: METRIC_LABELS[m] for m in RANKABLE_METRICS}


def active_rule(ok: Sequence[Mapping[str, Any]], rule: Sequence[str] | None = None) -> tuple[str, ...]:
    """The metrics of ``rule`` (default :data:`DEFAULT_RULE`) that some row of ``ok`` holds."""
    return tuple(f for f in (rule or DEFAULT_RULE) if any(num(r.get(f)) is not None for r in ok))


def paired_p(a: Sequence[float], y: Sequence[float]) -> float:
    """Two-sided p of the paired t-test of ``y - a`` (see the module docstring for the edge cases).

    >>> paired_p([1.0, 2.0], [1.5, 2.5]), paired_p([1.0], [3.0])
    (0.0, 1.0)
    """
    from scipy.stats import ttest_rel

    d = [v - u for u, v in zip(a, y)]
    if len(d) < 2:
        return 1.0
    if max(d) - min(d) <= 1e-12 * max(1.0, max(abs(x) for x in d)):
        return 1.0 if abs(d[0]) <= 1e-12 else 0.0
    return float(ttest_rel(y, a).pvalue)


def pairwise_tests(ok: Sequence[dict], names: Sequence[str], metric: str) -> list[dict[str, Any]]:
    """One record per pair of ``names`` (``a`` before ``b`` in ``names``): ``mean_diff`` (a - b),
    ``n`` seeds, ``p``, ``p_holm`` (Holm over the pairs given) and ``separated``."""
    from statsmodels.stats.multitest import multipletests

    index = {(r["condition_id"], r["enhancer"]): r for r in ok}
    recs = []
    for a, b in itertools.combinations(names, 2):
        pairs = [(r, index[(r["condition_id"], b)]) for r in ok if r["enhancer"] == a and (r["condition_id"], b) in index]
        xa, xb = per_seed_pairs(pairs, metric)
        mean = sum(u - v for u, v in zip(xa, xb)) / len(xa) if xa else None
        recs.append({"system_a": a, "system_b": b, "metric": metric, "n": len(xa), "mean_diff": mean,
                     "p": paired_p(xa, xb) if xa else 1.0})  # fmt: skip
    if recs:
        adjusted = multipletests([r["p"] for r in recs], alpha=ALPHA, method="holm")[1]
        for r, p in zip(recs, adjusted):
            r["p_holm"] = float(p)
            r["separated"] = bool(p < ALPHA)
    return recs


def letters(names: Sequence[str], tests: Sequence[Mapping[str, Any]]) -> dict[str, str]:
    """Compact letters of ``names`` (in this order, ``a`` first) from :func:`pairwise_tests`."""
    import numpy as np
    from scikit_posthocs import compact_letter_display

    if len(names) < 2:
        return {n: "a" for n in names}
    pos = {n: i for i, n in enumerate(names)}
    p = np.ones((len(names), len(names)))
    for t in tests:
        i, j = pos[t["system_a"]], pos[t["system_b"]]
        p[i, j] = p[j, i] = t["p_holm"]
    cld = compact_letter_display(p, alpha=ALPHA, names=list(names))
    return {n: str(cld[n]).replace(" ", "") for n in names}


def _order_key(rec: Mapping[str, Any], rule: Sequence[str]) -> tuple:
    return tuple(-(rec[f] if rec.get(f) is not None else -math.inf) for f in rule) + (rec["enhancer"],)


def rank_groups(
    ok: Sequence[dict], rule: Sequence[str] | None = None, *, flagged: Callable[[dict], bool] = lambda r: False
) -> list[dict[str, Any]]:
    """Systems of one stratum ordered by ``rule``, with ``tier`` = the letters of its first
    metric (and ``letters_<metric>`` for each), the seed means and intervals, ``n`` seeds,
    ``black_box`` and ``flagged`` counts; ``tests`` holds every metric's pairwise records."""
    rule = active_rule(ok, rule)
    recs = []
    for name in sorted({r["enhancer"] for r in ok}):
        mine = [r for r in ok if r["enhancer"] == name]
        rec: dict[str, Any] = {"enhancer": name, "n": len({r.get("seed") for r in mine})}
        for f in rule:
            rec[f], rec[f + "_lo"], rec[f + "_hi"] = seed_interval(seed_means(mine, f), f)
        rec["black_box"] = any(r.get("snr_method") == "phase-inversion" for r in mine)
        rec["flagged"] = sum(bool(flagged(r)) for r in mine)
        recs.append(rec)
    recs.sort(key=lambda r: _order_key(r, rule))
    names = [r["enhancer"] for r in recs]
    for f in rule:
        ordered = sorted(names, key=lambda n: _order_key(next(r for r in recs if r["enhancer"] == n), (f,)))
        tests = pairwise_tests(ok, ordered, f)
        lett = letters(ordered, tests)
        for r in recs:
            r["letters_" + f] = lett[r["enhancer"]]
            r.setdefault("tests", []).extend(tests)
    for r in recs:
        r["tier"] = r.get("letters_" + rule[0], "") if rule else ""
    return recs


def _cell(rec: Mapping[str, Any], f: str) -> str:
    if rec.get(f) is None:
        return "–"
    d = digits_for(f)
    lo, hi = fmt(rec[f + "_lo"], d), fmt(rec[f + "_hi"], d)
    spread = "" if rec["n"] < 2 or lo == hi else f" ({lo} … {hi})"
    return f"{fmt(rec[f], d)}{spread} **{rec['letters_' + f]}**"


def _mark(rec: Mapping[str, Any]) -> str:
    return f"`{rec['enhancer']}`" + (" †" if rec.get("black_box") else "") + (" ‡" if rec.get("flagged") else "")


def _pairs_table(recs: Sequence[dict], metric: str) -> list[str]:
    """The pairwise comparisons of ``metric`` behind the letters (folded: k (k-1) / 2 rows)."""
    tests = [t for t in recs[0]["tests"] if t["metric"] == metric] if recs else []
    if not tests:
        return []
    d = digits_for(metric)
    body = [[f"`{t['system_a']}` − `{t['system_b']}`", "–" if t["mean_diff"] is None else f"{t['mean_diff']:+.{d}f}",
             str(t["n"]), f"{t['p']:.3g}", f"{t['p_holm']:.3g}", "separated" if t["separated"] else "not separated"]
            for t in tests]  # fmt: skip
    table = markdown_table(["pair", f"mean Δ {RANKABLE.get(metric, metric)}", "n seeds", "p", "p (Holm)", "test"], body)
    return [f"<details><summary>System vs system, {RANKABLE.get(metric, metric)} ({len(body)} pairs)</summary>",
            "", table, "", "</details>", ""]  # fmt: skip


def headline_lines(label: str, recs: Sequence[dict], rule: Sequence[str]) -> list[str]:
    """One "system x metric" table of a stratum: mean (seeds' interval) and letters per metric."""
    head = ["rank", "system", *(RANKABLE.get(f, f) for f in rule), "n seeds"]
    body = [[str(i + 1), _mark(r), *(_cell(r, f) for f in rule), str(r["n"])] for i, r in enumerate(recs)]
    return [f"**{label}**", "", markdown_table(head, body), "", *(ln for f in rule[:1] for ln in _pairs_table(recs, f))]


def rule_text(rule: Sequence[str], configured: bool) -> str:
    """The ranking rule in words, as the report states it."""
    names = ", ".join(RANKABLE.get(f, f) for f in rule)
    source = "the sweep's `ranking` key" if configured else "the default: the field's metrics"
    return (f"ordered by {names} ({source}); letters per metric from pairwise paired t-tests over seeds "
            f"(each seed's mean over the conditions both systems have), Holm-corrected within the table, "
            f"α = {ALPHA:g}: **two systems share a letter exactly when the test does not separate them**; "
            "the `tier` of `ranking.csv` is the first metric's letters. † black box (phase inversion), "
            "‡ has flagged rows")


def ranking_section(
    ok: Sequence[dict], report_dir: Path, *, rule: Sequence[str] | None = None, flagged=lambda r: False
) -> tuple[list[str], list[Path]]:
    """The "Ranking" section (one headline table per stratum), ``ranking.csv`` and ``pairwise.csv``."""
    active = active_rule(ok, rule)
    if not ok or not active:
        return [], []
    lines, records, pairs = [], [], []
    for label, rows in strata(ok):
        recs = rank_groups(rows, active, flagged=flagged)
        lines += headline_lines(label, recs, active)
        where = {"noise": rows[0].get("noise"), "rt60_s": rows[0].get("rt60_s") if "RT60" in label else None}
        records += [{**r, **where, "stratum": label} for r in recs]
        pairs += [{**t, "stratum": label} for t in (recs[0]["tests"] if recs else [])]
    cols = ["noise", "rt60_s", "stratum", "tier", "enhancer", "n", "black_box", "flagged",
            *(x for f in active for x in (f, f + "_lo", f + "_hi", "letters_" + f))]  # fmt: skip
    paths = [write_csv(report_dir / "ranking.csv", records, cols),
             write_csv(report_dir / "pairwise.csv", pairs, ["stratum", "metric", "system_a", "system_b", "n",
                                                            "mean_diff", "p", "p_holm", "separated"])]  # fmt: skip
    head = ["## Ranking", "", f"Rule: {rule_text(active, bool(rule))}.", "", "Why letters: " + _WHY, ""]
    return [*head, *lines], paths


_WHY = ("pairwise tests are not transitive, so strict tiers cannot always exist; a critical-difference "
        "diagram (Friedman + Nemenyi over conditions) would test mean ranks over conditions, not the "
        "paired differences over seeds the verdicts show, and could contradict them.")

__all__ = ["ALPHA", "DEFAULT_RULE", "RANKABLE", "active_rule", "headline_lines", "letters", "paired_p",
           "pairwise_tests", "rank_groups", "ranking_section", "rule_text", "strata"]
