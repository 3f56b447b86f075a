"""Statistics that decide: paired verdicts against baselines and a ranking with tiers.

* :func:`paired_verdicts` -- each system against ``passthrough`` and against ``ss`` (the best
  single-channel baseline), per noise and metric: the difference ``system - baseline`` on the
  *same* conditions (rows paired by ``condition_id``), averaged within each seed over that
  seed's conditions, then mean and 95 % Student-t interval over the seeds
  (:func:`benchmarks.report.compare.paired_ci`, equal to ``scipy.stats.ttest_rel``'s interval), ``n``
  seeds and a verdict: *better* (interval above 0), *worse* (below 0), else *not resolved*.
  One seed gives no interval: never resolved.
* :func:`rank_tiers` -- the stated rule :data:`RANKING_RULE`: systems ordered by raw PESQ,
  then STOI, then SNR-I (means over seeds of each seed's mean over the noises' conditions);
  a system whose raw-PESQ interval overlaps the tier leader's joins its tier.  Black boxes
  (``snr_method = 'phase-inversion'``) and systems with flagged rows are marked.

Rows are :func:`benchmarks.report.tables.normalise_rows` rows, ``status == 'ok'``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.report.compare import paired_ci
from benchmarks.report.tables import (
    MIN_T_SEEDS,
    clip_interval,
    digits_for,
    fmt,
    markdown_table,
    num,
    seed_interval,
    seed_means,
    write_csv,
)
from benchmarks.thesis import reference as T

#: Baselines every system is compared with (those present in the rows).
BASELINES = ("passthrough", "ss")
#: Metrics of the verdicts, in the order of the ranking rule's keys.
VERDICT_METRICS = ("pesq_nb_raw_out", "stoi_out", "snr_i_db")
RANKING_RULE = (
    "ranked by raw PESQ (P.862) out, then STOI out, then SNR-I; each a mean over seeds of the "
    "seed's mean over the noise's conditions; systems whose 95 % raw-PESQ interval overlaps the "
    "tier leader's share its tier (with fewer than 5 seeds the seeds' min–max stands in for "
    "the interval); † black box (measured by phase inversion), ‡ has flagged rows"
)


def _per_seed(pairs: Sequence[tuple[dict, dict]], metric: str) -> tuple[list[float], list[float]]:
    """Per seed, the means over its conditions of the baseline's and the system's ``metric``."""
    by_seed: dict[Any, list[tuple[float, float]]] = {}
    for b, x in pairs:
        vb, vx = num(b.get(metric)), num(x.get(metric))
        if vb is not None and vx is not None:
            by_seed.setdefault(b.get("seed"), []).append((vb, vx))
    a = [sum(v for v, _ in p) / len(p) for p in by_seed.values()]
    y = [sum(v for _, v in p) / len(p) for p in by_seed.values()]
    return a, y


def verdict(lo: float | None, hi: float | None) -> str:
    """"better" / "worse" / "not resolved" for an interval of ``system - baseline``.

    >>> verdict(0.1, 2.0), verdict(-3.0, -0.2), verdict(-1.0, 1.0), verdict(None, None)
    ('better', 'worse', 'not resolved', 'not resolved')
    """
    if lo is None or hi is None:
        return "not resolved"
    return "better" if lo > 0 else "worse" if hi < 0 else "not resolved"


def paired_verdicts(ok: Sequence[dict], metrics: Sequence[str] = VERDICT_METRICS) -> list[dict[str, Any]]:
    """One record per (noise, baseline, system, metric); see the module docstring.

    >>> rows = [dict(condition_id=f"c{s}", seed=s, noise="w", enhancer=e, snr_i_db=v + s)
    ...         for s in range(3) for e, v in (("ss", 1.0), ("eb", 3.0))]
    >>> r = paired_verdicts(rows, ("snr_i_db",))[0]
    >>> r["system"], r["baseline"], float(r["mean_diff"]), r["n"], r["verdict"]
    ('eb', 'ss', 2.0, 3, 'better')
    """
    index = {(r["condition_id"], r["enhancer"]): r for r in ok}
    out = []
    names = {r["enhancer"] for r in ok}
    for baseline in (n for b in BASELINES for n in sorted(names) if T.base_name(n) == b):
        systems = T.system_order({r["enhancer"] for r in ok} - {baseline})
        for noise in sorted({str(r["noise"]) for r in ok}):
            base_rows = [r for r in ok if r["enhancer"] == baseline and str(r["noise"]) == noise]
            for name in systems:
                pairs = [(b, index[(b["condition_id"], name)]) for b in base_rows if (b["condition_id"], name) in index]
                for metric in metrics:
                    a, y = _per_seed(pairs, metric)
                    if not a:
                        continue
                    stat = paired_ci(a, y)
                    lo, hi = (None, None) if stat.ci_low is None else (stat.ci_low, stat.ci_high)
                    diffs = [v - u for u, v in zip(a, y)]
                    out.append({"noise": noise, "baseline": baseline, "system": name, "metric": metric,
                                "n": stat.n, "mean_diff": stat.mean_diff, "ci_low": lo, "ci_high": hi,
                                "min_diff": min(diffs), "max_diff": max(diffs), "verdict": verdict(lo, hi)})  # fmt: skip
    return out


def diff_cell(rec: Mapping[str, Any]) -> str:
    """``+1.2 [0.3, 2.1]`` (n >= 5, t-interval clipped to the metric's range, ``*`` when clipped)
    or ``+1.2 (0.8 … 1.6)`` (the seeds' min and max, n < 5), then the verdict.

    >>> diff_cell(dict(metric="snr_i_db", n=2, mean_diff=1.0, min_diff=0.5, max_diff=1.5,
    ...                ci_low=-5.4, ci_high=7.4, verdict="not resolved"))
    '+1.0 (seeds +0.5 … +1.5) not resolved'
    """
    d = digits_for(rec["metric"])

    def s(x):
        return "–" if x is None else f"{0.0 if round(x, d) == 0 else x:+.{d}f}"  # no "-0.0"

    mean = s(rec["mean_diff"])
    if rec["n"] < 2:
        body = f"{mean} (n = 1)"
    elif rec["n"] < MIN_T_SEEDS:
        body = f"{mean} (seeds {s(rec['min_diff'])} … {s(rec['max_diff'])})"
    else:
        lo, hi = clip_interval(rec["metric"].replace("_out", "_i"), rec["ci_low"], rec["ci_high"])
        star = "*" if (lo, hi) != (rec["ci_low"], rec["ci_high"]) else ""
        body = f"{mean} [{s(lo)}, {s(hi)}]{star}"
    return f"{body} {rec['verdict']}"


def rank_tiers(
    ok: Sequence[dict], *, flagged: Callable[[dict], bool] = lambda r: False
) -> list[dict[str, Any]]:
    """Systems of ``ok`` (one noise, or all) ranked by :data:`RANKING_RULE`, with tiers.

    >>> rows = [dict(enhancer=e, seed=s, pesq_nb_raw_out=p + 0.01 * s, stoi_out=0.8, snr_i_db=1.0)
    ...         for s in range(5) for e, p in (("a", 2.0), ("b", 2.02), ("c", 3.0))]
    >>> [(r["enhancer"], r["tier"]) for r in rank_tiers(rows)]
    [('c', 1), ('b', 2), ('a', 2)]
    """
    recs = []
    for name in {r["enhancer"] for r in ok}:
        rec: dict[str, Any] = {"enhancer": name}
        for f in VERDICT_METRICS:
            vals = seed_means([r for r in ok if r["enhancer"] == name], f)
            rec[f], rec[f + "_lo"], rec[f + "_hi"] = seed_interval(vals, f)
            rec["n"] = max(rec.get("n", 0), len(vals))
        mine = [r for r in ok if r["enhancer"] == name]
        rec["black_box"] = any(r.get("snr_method") == "phase-inversion" for r in mine)
        rec["flagged"] = sum(bool(flagged(r)) for r in mine)
        recs.append(rec)
    key = VERDICT_METRICS[0]
    recs.sort(key=lambda r: tuple(-(r[f] if r[f] is not None else float("-inf")) for f in VERDICT_METRICS))
    tier, leader = 0, None
    for rec in recs:
        if leader is None or rec[key] is None or leader[key] is None or rec[key + "_hi"] < leader[key + "_lo"]:
            tier, leader = tier + 1, rec
        rec["tier"] = tier
    return recs


def ranking_cell(rec: Mapping[str, Any], field: str) -> str:
    """``mean (lo … hi)`` of a :func:`rank_tiers` record."""
    d = digits_for(field)
    if rec.get(field) is None:
        return "–"
    lo, hi = fmt(rec[field + "_lo"], d), fmt(rec[field + "_hi"], d)
    if rec["n"] < 2 or lo == hi:
        return fmt(rec[field], d)
    return f"{fmt(rec[field], d)} ({lo} … {hi})"


def system_mark(rec: Mapping[str, Any]) -> str:
    """The system's name with † (black box) and ‡ (flagged rows) marks."""
    return f"`{rec['enhancer']}`" + (" †" if rec.get("black_box") else "") + (" ‡" if rec.get("flagged") else "")


_LABELS = {"pesq_nb_raw_out": "Δ PESQ raw", "stoi_out": "Δ STOI", "snr_i_db": "Δ SNR-I (dB)"}


def _verdict_tables(recs: Sequence[dict]) -> list[str]:
    """One table per baseline: a line per (system, noise), a cell per metric."""
    lines: list[str] = []
    for baseline in dict.fromkeys(r["baseline"] for r in recs):
        mine = [r for r in recs if r["baseline"] == baseline]
        keyed = {(r["system"], r["noise"], r["metric"]): r for r in mine}
        pairs = list(dict.fromkeys((r["system"], r["noise"]) for r in mine))
        pairs.sort(key=lambda k: (T.system_rank(k[0]), k[0], k[1]))
        body = []
        for name, noise in pairs:
            cells = [diff_cell(keyed[(name, noise, m)]) if (name, noise, m) in keyed else "–" for m in VERDICT_METRICS]
            n = max(keyed[(name, noise, m)]["n"] for m in VERDICT_METRICS if (name, noise, m) in keyed)
            body.append([f"`{name}`", noise, str(n), *cells])
        lines += [f"### Against `{baseline}`", "",
                  markdown_table(["system", "noise", "n seeds", *(_LABELS[m] for m in VERDICT_METRICS)], body), ""]  # fmt: skip
    return lines


#: Shown beside the ranking when the rows have them (a sweep's ``metrics = ["dnsmos"]``); not ranked on.
SHOWN_METRICS = {"dnsmos_ovrl": "DNSMOS OVRL", "dnsmos_sig": "DNSMOS SIG", "dnsmos_bak": "DNSMOS BAK"}


def _add_shown(rec: dict[str, Any], rows: Sequence[dict], fields: Sequence[str]) -> dict[str, Any]:
    """``rec`` with ``field``, ``field_lo``, ``field_hi`` (seed interval) of each of ``fields``."""
    for f in fields:
        rec[f], rec[f + "_lo"], rec[f + "_hi"] = seed_interval(seed_means(rows, f), f)
    return rec


def _ranking_tables(ok: Sequence[dict], flagged, shown: Sequence[str]) -> tuple[list[str], list[dict]]:
    """One ranking table per noise, with the ``shown`` columns (of :data:`SHOWN_METRICS`) after the ranked ones."""
    lines, records = [], []
    for noise in sorted({str(r["noise"]) for r in ok}):
        mine = [r for r in ok if str(r["noise"]) == noise]
        ranked = [_add_shown(r, [x for x in mine if x["enhancer"] == r["enhancer"]], shown)
                  for r in rank_tiers(mine, flagged=flagged)]
        records += [{**r, "noise": noise} for r in ranked]
        body = [[str(r["tier"]), system_mark(r), *(ranking_cell(r, f) for f in (*VERDICT_METRICS, *shown)),
                 str(r["n"])] for r in ranked]  # fmt: skip
        head = ["tier", "system", "PESQ out raw", "STOI out", "SNR-I (dB)", *(SHOWN_METRICS[f] for f in shown)]
        lines += [f"**{noise}**", "", markdown_table([*head, "n seeds"], body), ""]
    return lines, records


def verdicts_section(ok: Sequence[dict], report_dir: Path, *, flagged=lambda r: False) -> tuple[list[str], list[Path]]:
    """The "Paired verdicts and ranking" section and ``verdicts.csv`` / ``ranking.csv``."""
    recs = paired_verdicts(ok)
    if not recs:
        return [], []
    shown = [f for f in SHOWN_METRICS if any(num(r.get(f)) is not None for r in ok)]  # DNSMOS when opted in
    rank_lines, ranked = _ranking_tables(ok, flagged, shown)
    paths = [
        write_csv(report_dir / "verdicts.csv", recs, ["noise", "baseline", "system", "metric", "n", "mean_diff",
                                                      "ci_low", "ci_high", "min_diff", "max_diff", "verdict"]),
        write_csv(report_dir / "ranking.csv", ranked, ["noise", "tier", "enhancer", "n", "black_box", "flagged",
                                                       *(x for f in (*VERDICT_METRICS, *shown)
                                                         for x in (f, f + "_lo", f + "_hi"))]),
    ]  # fmt: skip
    n = max(r["n"] for r in recs)
    lines = [
        "## Paired verdicts and ranking",
        "",
        "Each system minus the baseline on the **same conditions** (paired by condition), averaged "
        "within each seed, then over the seeds: mean difference and "
        + (f"95 % Student-t interval (n ≥ {MIN_T_SEEDS}; `[lo, hi]*` when clipped to the metric's range)"
           if n >= MIN_T_SEEDS else f"the seeds' min … max (n < {MIN_T_SEEDS}: no t-interval is shown)")
        + ". Verdict: *better* / *worse* when the 95 % t-interval excludes 0, else *not resolved* "
        "(one seed is never resolved). Higher is better for every column.",
        "",
        *_verdict_tables(recs),
        "### Ranking",
        "",
        f"Rule: {RANKING_RULE}." + (" DNSMOS P.835 (non-intrusive, first output channel) is shown, "
                                    "not ranked on." if shown else ""),
        "",
        *rank_lines,
    ]
    return lines, paths


__all__ = ["BASELINES", "RANKING_RULE", "SHOWN_METRICS", "VERDICT_METRICS", "diff_cell", "paired_verdicts", "rank_tiers",
           "ranking_cell", "system_mark", "verdict", "verdicts_section"]
