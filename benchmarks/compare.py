"""``scenesim bench compare DIR_A DIR_B``: paired differences between two stores of one sweep.

Rows are matched on ``(condition_id, enhancer)``; the two stores must hold the same
conditions (else :class:`SweepMismatch`).  A *group* is a condition without its seed
(same scene, noise, SNR, ...) and one enhancer; over its seeds the paired differences
``d_k = B_k - A_k`` of each metric give

    mean  d_bar = sum(d_k) / n,    s = sqrt(sum((d_k - d_bar)^2) / (n - 1)),
    95 % CI  d_bar -/+ t_{0.975, n-1} s / sqrt(n)      (Student t, two-sided)

with ``n`` the seeds where both rows are ``ok`` and the metric is present.  With ``n = 1``
there is no interval.  (Equivalent to ``scipy.stats.ttest_rel(B, A).confidence_interval()``.)
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenesim.errors import ParameterError, ScenesimError

#: Metrics compared by default (the inputs are the same in both stores, so an output
#: difference is also the difference of improvements).
DEFAULT_METRICS = ("snr_i_db", "pesq_nb_out", "pesq_wb_out", "stoi_out", "estoi_out", "si_sdr_out_db")
CONFIDENCE = 0.95
# Used when a row lacks condition_json (hand-made stores): the contract's condition columns.
_FALLBACK_KEYS = ("noise", "snr_in_db", "rt60_s", "speech_az_deg", "noise_az_deg")
_LABEL_KEYS = ("noise", "snr_db", "rt60_s", "speech_az_deg", "noise_az_deg", "noise_field", "room")


class SweepMismatch(ScenesimError):
    """The two stores do not hold the same sweep (different conditions, no common enhancer)."""


@dataclass(frozen=True)
class PairedStat:
    """Paired difference B - A of one metric over the seeds of one group."""

    n: int
    mean_a: float | None
    mean_b: float | None
    mean_diff: float | None
    sd_diff: float | None
    ci_low: float | None
    ci_high: float | None


def paired_ci(a: Sequence[float], b: Sequence[float], *, confidence: float = CONFIDENCE) -> PairedStat:
    """Mean of ``b - a`` with its Student-t confidence interval (see the module docstring).

    >>> s = paired_ci([1.0, 2.0, 3.0], [2.0, 2.5, 4.5])
    >>> round(s.mean_diff, 3), s.n
    (1.0, 3)
    """
    from scipy.stats import t as student_t

    if len(a) != len(b):
        raise ValueError("paired samples need equal lengths")
    n = len(a)
    if n == 0:
        return PairedStat(0, None, None, None, None, None, None)
    d = [y - x for x, y in zip(a, b)]
    mean = sum(d) / n
    mean_a, mean_b = sum(a) / n, sum(b) / n
    if n == 1:
        return PairedStat(1, mean_a, mean_b, mean, None, None, None)
    sd = math.sqrt(sum((x - mean) ** 2 for x in d) / (n - 1))
    half = float(student_t.ppf(0.5 + confidence / 2, n - 1)) * sd / math.sqrt(n)
    return PairedStat(n, mean_a, mean_b, mean, sd, mean - half, mean + half)


def _group_key(row: Mapping[str, Any]) -> str:
    text = row.get("condition_json")
    if text:
        params = json.loads(text)
        params.pop("seed", None)
    else:
        params = {k: row.get(k) for k in _FALLBACK_KEYS}
    return json.dumps(params, sort_keys=True)


def _label(group: str) -> dict[str, Any]:
    params = json.loads(group)
    if "snr_db" not in params and "snr_in_db" in params:
        params["snr_db"] = params["snr_in_db"]
    return {k: params.get(k) for k in _LABEL_KEYS}


def check_metric_columns(rows: Sequence[Mapping[str, Any]], metrics: Sequence[str]) -> None:
    """Raise a ParameterError naming ``--metrics`` for a column that holds text, or an unknown name
    (the default metrics are known names: stores written before a column existed lack it)."""
    columns = list(rows[0]) if rows else []
    for metric in metrics:
        texts = [r[metric] for r in rows if isinstance(r.get(metric), str)] if metric in columns else []
        if texts or (metric not in columns and metric not in DEFAULT_METRICS):
            what = "a text column" if texts else "not a column of the store"
            raise ParameterError("--metrics", metric, f"a numeric result column ({metric!r} is {what}); e.g. "
                                 + ", ".join(c for c in DEFAULT_METRICS if c in columns))


def compare_rows(
    rows_a: Sequence[Mapping[str, Any]],
    rows_b: Sequence[Mapping[str, Any]],
    *,
    metrics: Sequence[str] = DEFAULT_METRICS,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Paired statistics per (group, enhancer, metric); ``(records, notes)``.

    Raises
    ------
    SweepMismatch
        If the stores' condition ids differ or they share no enhancer.
    """
    check_metric_columns(rows_a, metrics)
    conds_a = {r["condition_id"] for r in rows_a}
    conds_b = {r["condition_id"] for r in rows_b}
    if conds_a != conds_b:
        raise SweepMismatch(
            f"the stores hold different sweeps: {len(conds_a - conds_b)} condition(s) only in A, "
            f"{len(conds_b - conds_a)} only in B (compare needs the same conditions)"
        )
    names_a = {r["enhancer"] for r in rows_a}
    names_b = {r["enhancer"] for r in rows_b}
    common = sorted(names_a & names_b)
    if not common:
        raise SweepMismatch(
            f"the stores share no enhancer (A: {', '.join(sorted(names_a))}; B: {', '.join(sorted(names_b))})"
        )
    notes = [f"only in {w}: {', '.join(sorted(s))}" for w, s in (("A", names_a - names_b), ("B", names_b - names_a)) if s]
    index_b = {(r["condition_id"], r["enhancer"]): r for r in rows_b}
    pairs: dict[tuple[str, str], list[tuple[Mapping, Mapping]]] = {}
    n_unpaired = 0
    for ra in rows_a:
        if ra["enhancer"] not in common:
            continue
        rb = index_b[(ra["condition_id"], ra["enhancer"])]
        if ra.get("status") != "ok" or rb.get("status") != "ok":
            n_unpaired += 1
            continue
        pairs.setdefault((_group_key(ra), ra["enhancer"]), []).append((ra, rb))
    if n_unpaired:
        notes.append(f"{n_unpaired} (condition, enhancer) pair(s) left out: status 'error' in A or B")
    records = []
    for (group, name), rows in pairs.items():
        for metric in metrics:
            both = [(ra.get(metric), rb.get(metric)) for ra, rb in rows]
            both = [(float(x), float(y)) for x, y in both if x is not None and y is not None]
            stat = paired_ci([x for x, _ in both], [y for _, y in both])
            records.append({**_label(group), "enhancer": name, "metric": metric, **stat.__dict__})
    records.sort(key=lambda r: (r["enhancer"], *(str(r[k]) for k in _LABEL_KEYS), r["metric"]))
    return records, notes


def _fmt(x: float | None, digits: int = 2) -> str:
    return "–" if x is None else f"{x:+.{digits}f}"


def wide_table(records: Sequence[Mapping[str, Any]], metrics: Sequence[str]) -> tuple[list[str], list[list[str]]]:
    """Header and body: one line per (group, enhancer), one ``mean [lo, hi]`` cell per metric."""
    keys = [k for k in _LABEL_KEYS if len({str(r[k]) for r in records}) > 1] or ["noise", "snr_db"]
    lines: dict[tuple, dict[str, Any]] = {}
    for r in records:
        line = lines.setdefault((r["enhancer"], *(str(r[k]) for k in keys)), {"r": r, "n": 0})
        line[r["metric"]] = r
        line["n"] = max(line["n"], r["n"])
    header = ["enhancer", *keys, "n seeds", *(f"Δ {m} [95% CI]" for m in metrics)]
    body = []
    for line in lines.values():
        cells = [str(line["r"]["enhancer"]), *(_cell(line["r"][k]) for k in keys), str(line["n"])]
        for m in metrics:
            s = line.get(m)
            if s is None or s["mean_diff"] is None:
                cells.append("–")
            elif s["ci_low"] is None:
                cells.append(_fmt(s["mean_diff"], 3))
            else:
                cells.append(f"{_fmt(s['mean_diff'], 3)} [{_fmt(s['ci_low'], 3)}, {_fmt(s['ci_high'], 3)}]")
        body.append(cells)
    return header, body


def _cell(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


CSV_COLUMNS = (*_LABEL_KEYS, "enhancer", "metric", "n", "mean_a", "mean_b", "mean_diff", "sd_diff", "ci_low", "ci_high")


def compare_stores(
    dir_a: str | Path, dir_b: str | Path, *, out_dir: str | Path | None = None, metrics: Sequence[str] = DEFAULT_METRICS
) -> tuple[str, list[Path]]:
    """Compare two stores; write ``compare.csv`` (long) and ``compare.md`` (wide) to ``out_dir``.

    Returns the Markdown text (also printed by the CLI) and the written paths.  ``out_dir``
    defaults to ``DIR_B/compare``.
    """
    from benchmarks.report_tables import markdown_table
    from benchmarks.store import ResultStore

    with ResultStore.open(dir_a, readonly=True) as sa, ResultStore.open(dir_b, readonly=True) as sb:
        rows_a, rows_b = sa.rows(), sb.rows()
    records, notes = compare_rows(rows_a, rows_b, metrics=metrics)
    header, body = wide_table(records, metrics)
    text = "\n".join([
        f"# B − A: {dir_b} minus {dir_a}",
        "",
        f"Paired over seeds (B − A per condition), mean and {CONFIDENCE:.0%} Student-t CI; "
        "n = seeds where both rows are ok.",
        *(f"- {n}" for n in notes),
        "",
        markdown_table(header, body),
        "",
    ])  # fmt: skip
    out = Path(out_dir) if out_dir is not None else Path(dir_b) / "compare"
    out.mkdir(parents=True, exist_ok=True)
    md = out / "compare.md"
    md.write_text(text, encoding="utf-8")
    path_csv = out / "compare.csv"
    with path_csv.open("w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(records)
    return text, [md, path_csv]


__all__ = ["DEFAULT_METRICS", "PairedStat", "SweepMismatch", "compare_rows", "compare_stores", "paired_ci", "wide_table"]
