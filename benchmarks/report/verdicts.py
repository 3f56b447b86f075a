"""Paired verdicts: each system against the baselines, on the same conditions.

* :func:`paired_verdicts` -- each system against ``passthrough`` and against ``ss`` (the best
  single-channel baseline), per stratum (a noise; a noise and an RT60 when RT60 is swept: never
  pooled over it) and metric: the difference ``system - baseline`` on the *same* conditions
  (rows paired by ``condition_id``), averaged within each seed over that seed's conditions,
  then mean and 95 % Student-t interval over the seeds
  (:func:`benchmarks.report.compare.paired_ci`, equal to ``scipy.stats.ttest_rel``'s interval), ``n``
  seeds and a verdict: *better* (interval above 0), *worse* (below 0), else *not resolved*.
  One seed gives no interval: never resolved.

The metrics are the report's ranking rule (:mod:`benchmarks.report.ranking`: by default the
field's wide-band PESQ, ESTOI, SI-SDR and DNSMOS where computed) plus SNR-I and, for
reverberation studies, SINR-I and SRMR.  The ranking's groups come from the same paired test
(system against system, Holm-corrected), so the two never disagree.

Rows are :func:`benchmarks.report.tables.normalise_rows` rows, ``status == 'ok'``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.report.compare import paired_ci
from benchmarks.report.tables import (
    MIN_T_SEEDS,
    clip_interval,
    digits_for,
    markdown_table,
    num,
    write_csv,
)
from benchmarks.thesis import reference as T

#: Baselines every system is compared with (those present in the rows).
BASELINES = ("passthrough", "ss")
#: Metrics judged beside the ranking rule's: SNR-I, and the reverberation study's SINR-I and SRMR.
EXTRA_VERDICT_METRICS = ("snr_i_db", "sinr_i_db", "srmr_out")
#: Column labels of the metrics a verdict or a ranking may use (output-side, higher is better).
METRIC_LABELS = {
    "pesq_wb_out": "PESQ wb (MOS-LQO)", "pesq_nb_out": "PESQ nb (MOS-LQO)", "pesq_nb_raw_out": "PESQ raw",
    "estoi_out": "ESTOI", "stoi_out": "STOI", "si_sdr_out_db": "SI-SDR (dB)", "si_sdr_i_db": "SI-SDR-I (dB)",
    "snr_i_db": "SNR-I (dB)", "sinr_i_db": "SINR-I (dB)", "srmr_out": "SRMR", "dnsmos_ovrl": "DNSMOS OVRL",
    "dnsmos_sig": "DNSMOS SIG", "dnsmos_bak": "DNSMOS BAK", "dnsmos_p808": "DNSMOS P.808",
}  # fmt: skip


def strata(ok: Sequence[Mapping[str, Any]]) -> list[tuple[str, list]]:
    """``(label, rows)`` per noise, or per (noise, RT60) when the rows hold several RT60s:
    a swept RT60 is never pooled.

    >>> [k for k, _ in strata([{"noise": "b", "rt60_s": 0.3}, {"noise": "b", "rt60_s": 0.6}])]
    ['b, RT60 0.3 s', 'b, RT60 0.6 s']
    """
    rt60s = sorted({num(r.get("rt60_s")) or 0.0 for r in ok})
    out = []
    for noise in sorted({str(r.get("noise")) for r in ok}):
        mine = [r for r in ok if str(r.get("noise")) == noise]
        for rt in rt60s if len(rt60s) > 1 else (None,):
            sel = mine if rt is None else [r for r in mine if (num(r.get("rt60_s")) or 0.0) == rt]
            if sel:
                out.append((noise if rt is None else f"{noise}, RT60 {rt:g} s", sel))
    return out


def per_seed_pairs(pairs: Sequence[tuple[dict, dict]], metric: str) -> tuple[list[float], list[float]]:
    """Per seed, the means over its conditions of the first and the second row's ``metric``.

    >>> per_seed_pairs([({"seed": 0, "x": 1.0}, {"seed": 0, "x": 2.0}),
    ...                 ({"seed": 0, "x": 3.0}, {"seed": 0, "x": 6.0})], "x")
    ([2.0], [4.0])
    """
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


def _verdict_record(pairs, metric: str, stratum: str, baseline: str, name: str) -> dict[str, Any] | None:
    a, y = per_seed_pairs(pairs, metric)
    if not a:
        return None
    stat = paired_ci(a, y)
    lo, hi = (None, None) if stat.ci_low is None else (stat.ci_low, stat.ci_high)
    diffs = [v - u for u, v in zip(a, y)]
    return {"noise": stratum, "baseline": baseline, "system": name, "metric": metric, "n": stat.n,
            "mean_diff": stat.mean_diff, "ci_low": lo, "ci_high": hi, "min_diff": min(diffs),
            "max_diff": max(diffs), "verdict": verdict(lo, hi)}  # fmt: skip


def paired_verdicts(ok: Sequence[dict], metrics: Sequence[str] = ("snr_i_db",)) -> list[dict[str, Any]]:
    """One record per (stratum, baseline, system, metric); see the module docstring.

    The record's ``noise`` is the stratum's label (:func:`strata`: the noise, with its RT60
    when RT60 is swept).

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
        systems = T.system_order(names - {baseline})
        for label, rows in strata(ok):
            base_rows = [r for r in rows if r["enhancer"] == baseline]
            for name in systems:
                pairs = [(b, index[(b["condition_id"], name)]) for b in base_rows if (b["condition_id"], name) in index]
                recs = (_verdict_record(pairs, m, label, baseline, name) for m in metrics)
                out += [r for r in recs if r is not None]
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


def _verdict_tables(recs: Sequence[dict], metrics: Sequence[str]) -> list[str]:
    """One table per baseline: a line per (system, stratum), a cell per metric."""
    lines: list[str] = []
    for baseline in dict.fromkeys(r["baseline"] for r in recs):
        mine = [r for r in recs if r["baseline"] == baseline]
        keyed = {(r["system"], r["noise"], r["metric"]): r for r in mine}
        pairs = list(dict.fromkeys((r["system"], r["noise"]) for r in mine))
        pairs.sort(key=lambda k: (T.system_rank(k[0]), k[0], k[1]))
        body = []
        for name, noise in pairs:
            cells = [diff_cell(keyed[(name, noise, m)]) if (name, noise, m) in keyed else "–" for m in metrics]
            n = max(keyed[(name, noise, m)]["n"] for m in metrics if (name, noise, m) in keyed)
            body.append([f"`{name}`", noise, str(n), *cells])
        head = ["system", "noise", "n seeds", *("Δ " + METRIC_LABELS.get(m, m) for m in metrics)]
        lines += [f"### Against `{baseline}`", "", markdown_table(head, body), ""]
    return lines


def verdicts_section(ok: Sequence[dict], report_dir: Path, *, metrics: Sequence[str]) -> tuple[list[str], list[Path]]:
    """The "Paired verdicts" section and ``verdicts.csv`` for ``metrics`` (those the rows hold)."""
    metrics = [m for m in dict.fromkeys(metrics) if any(num(r.get(m)) is not None for r in ok)]
    recs = paired_verdicts(ok, metrics)
    if not recs:
        return [], []
    paths = [write_csv(report_dir / "verdicts.csv", recs, ["noise", "baseline", "system", "metric", "n", "mean_diff",
                                                           "ci_low", "ci_high", "min_diff", "max_diff", "verdict"])]  # fmt: skip
    n = max(r["n"] for r in recs)
    lines = [
        "## Paired verdicts",
        "",
        "Each system minus the baseline on the **same conditions** (paired by condition), averaged "
        "within each seed, then over the seeds: mean difference and "
        + (f"95 % Student-t interval (n ≥ {MIN_T_SEEDS}; `[lo, hi]*` when clipped to the metric's range)"
           if n >= MIN_T_SEEDS else f"the seeds' min … max (n < {MIN_T_SEEDS}: no t-interval is shown)")
        + ". Verdict: *better* / *worse* when the 95 % t-interval excludes 0, else *not resolved* "
        "(one seed is never resolved; each comparison on its own, uncorrected -- the ranking below "
        "corrects for its many comparisons). Higher is better for every column. A swept RT60 is "
        "judged per RT60, never pooled.",
        "",
        *_verdict_tables(recs, metrics),
    ]  # fmt: skip
    return lines, paths


__all__ = ["BASELINES", "EXTRA_VERDICT_METRICS", "METRIC_LABELS", "diff_cell", "paired_verdicts", "per_seed_pairs",
           "strata", "verdict", "verdicts_section"]
