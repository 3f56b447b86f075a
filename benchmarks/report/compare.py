"""``scenesim bench compare DIR_A DIR_B``: differences between two stores of one sweep.

The output starts with what differs between the two sweeps' parameters (axes, seeds,
enhancers, enhancer parameters).  Rows are matched on ``(condition_id, enhancer)`` when the
two stores hold the same conditions.  Stores whose conditions differ only in their seeds
(e.g. ``--seeds 2`` against ``--seeds 5``, or ``--seed 100``) are compared **unpaired**: per
group, Welch's interval of the difference of the means over each store's seeds
(``scipy.stats.ttest_ind(B, A, equal_var=False).confidence_interval()``), and the output
says so.  Any other difference in conditions raises :class:`SweepMismatch`.  Lines where no
metric changed are hidden unless asked for.  A *group* is a condition without its seed
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenesim.errors import ParameterError, ScenesimError

#: Metrics compared by default (the inputs are the same in both stores, so an output
#: difference is also the difference of improvements).
DEFAULT_METRICS = ("snr_i_db", "pesq_nb_out", "pesq_wb_out", "stoi_out", "estoi_out", "si_sdr_out_db")
CONFIDENCE = 0.95
#: A metric whose difference is below this counts as unchanged (stored REALs round-trip exactly).
UNCHANGED_TOL = 1e-9
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
    from benchmarks.report.tables import mean_std, t_halfwidth

    if len(a) != len(b):
        raise ValueError("paired samples need equal lengths")
    n = len(a)
    if n == 0:
        return PairedStat(0, None, None, None, None, None, None)
    mean, sd, _ = mean_std([y - x for x, y in zip(a, b)])
    mean_a, mean_b = sum(a) / n, sum(b) / n
    if n == 1:
        return PairedStat(1, mean_a, mean_b, mean, None, None, None)
    half = t_halfwidth(sd, n, confidence)
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


def welch_ci(a: Sequence[float], b: Sequence[float], *, confidence: float = CONFIDENCE) -> PairedStat:
    """Mean of ``b`` minus mean of ``a`` with Welch's t-interval (unpaired samples).

    >>> s = welch_ci([1.0, 2.0, 3.0], [3.0, 4.0, 5.0])
    >>> float(s.mean_diff), s.n, round(s.ci_low, 3)
    (2.0, 3, -0.267)
    """
    from scipy.stats import ttest_ind

    n = min(len(a), len(b))
    mean_a = sum(a) / len(a) if a else None
    mean_b = sum(b) / len(b) if b else None
    if n == 0:
        return PairedStat(0, mean_a, mean_b, None, None, None, None)
    diff = mean_b - mean_a
    if n < 2:
        return PairedStat(n, mean_a, mean_b, diff, None, None, None)
    ci = ttest_ind(b, a, equal_var=False).confidence_interval(confidence)
    return PairedStat(n, mean_a, mean_b, diff, None, float(ci.low), float(ci.high))


def _check_same_sweep(rows_a, rows_b) -> bool:
    """True when the stores hold the same conditions, False when they differ only in seeds;
    else :class:`SweepMismatch`."""
    conds_a = {r["condition_id"] for r in rows_a}
    conds_b = {r["condition_id"] for r in rows_b}
    if conds_a == conds_b:
        return True
    seeds_a, seeds_b = {r.get("seed") for r in rows_a}, {r.get("seed") for r in rows_b}
    if seeds_a != seeds_b and {_group_key(r) for r in rows_a} == {_group_key(r) for r in rows_b}:
        return False
    raise SweepMismatch(
        f"the stores hold different sweeps: {len(conds_a - conds_b)} condition(s) only in A, "
        f"{len(conds_b - conds_a)} only in B (compare needs the same conditions, or conditions that differ only in seeds)"
    )


def compare_rows(
    rows_a: Sequence[Mapping[str, Any]],
    rows_b: Sequence[Mapping[str, Any]],
    *,
    metrics: Sequence[str] = DEFAULT_METRICS,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Statistics per (group, enhancer, metric); ``(records, notes)``.  Paired over seeds when
    the stores hold the same conditions, unpaired (Welch) when they differ only in seeds.

    Raises
    ------
    SweepMismatch
        If the stores' conditions differ otherwise or they share no enhancer.
    """
    check_metric_columns(rows_a, metrics)
    paired = _check_same_sweep(rows_a, rows_b)
    names_a = {r["enhancer"] for r in rows_a}
    names_b = {r["enhancer"] for r in rows_b}
    common = sorted(names_a & names_b)
    if not common:
        raise SweepMismatch(
            f"the stores share no enhancer (A: {', '.join(sorted(names_a))}; B: {', '.join(sorted(names_b))})"
        )
    notes = [f"only in {w}: {', '.join(sorted(s))}" for w, s in (("A", names_a - names_b), ("B", names_b - names_a)) if s]
    if paired:
        groups, n_unpaired = _paired_groups(rows_a, rows_b, common)
        if n_unpaired:
            notes.append(f"{n_unpaired} (condition, enhancer) pair(s) left out: status 'error' in A or B")
    else:
        groups = _unpaired_groups(rows_a, rows_b, common)
        seeds = [sorted({r.get("seed") for r in rows}) for rows in (rows_a, rows_b)]
        notes.append(f"the stores differ in their seeds (A: {_seed_text(seeds[0])}; B: {_seed_text(seeds[1])}): "
                     "compared **unpaired** -- difference of the means over each store's seeds, Welch t-interval")  # fmt: skip
    records = []
    for (group, name), (xs_a, xs_b) in groups.items():
        for metric in metrics:
            a = [float(r[metric]) for r in xs_a if r.get(metric) is not None]
            b = [float(r[metric]) for r in xs_b if r.get(metric) is not None]
            if paired:
                both = [(x.get(metric), y.get(metric)) for x, y in zip(xs_a, xs_b)]
                both = [(float(x), float(y)) for x, y in both if x is not None and y is not None]
                stat = paired_ci([x for x, _ in both], [y for _, y in both])
            else:
                stat = welch_ci(a, b)
            records.append({**_label(group), "enhancer": name, "metric": metric, "paired": paired, **stat.__dict__})
    records.sort(key=lambda r: (r["enhancer"], *(str(r[k]) for k in _LABEL_KEYS), r["metric"]))
    return records, notes


def _seed_text(seeds) -> str:
    return f"{len(seeds)} seed(s) {', '.join(str(s) for s in seeds[:6])}{' …' if len(seeds) > 6 else ''}"


def _paired_groups(rows_a, rows_b, common):
    """``{(group, enhancer): (rows of A, matching rows of B)}`` and the count of pairs left out."""
    index_b = {(r["condition_id"], r["enhancer"]): r for r in rows_b}
    groups: dict[tuple[str, str], tuple[list, list]] = {}
    n_unpaired = 0
    for ra in rows_a:
        if ra["enhancer"] not in common:
            continue
        rb = index_b[(ra["condition_id"], ra["enhancer"])]
        if ra.get("status") != "ok" or rb.get("status") != "ok":
            n_unpaired += 1
            continue
        xs_a, xs_b = groups.setdefault((_group_key(ra), ra["enhancer"]), ([], []))
        xs_a.append(ra)
        xs_b.append(rb)
    return groups, n_unpaired


def _unpaired_groups(rows_a, rows_b, common):
    """``{(group, enhancer): (ok rows of A, ok rows of B)}``, each over its own seeds."""
    groups: dict[tuple[str, str], tuple[list, list]] = {}
    for k, rows in enumerate((rows_a, rows_b)):
        for r in rows:
            if r["enhancer"] in common and r.get("status") == "ok":
                groups.setdefault((_group_key(r), r["enhancer"]), ([], []))[k].append(r)
    return groups


def _fmt(x: float | None, digits: int = 2) -> str:
    return "–" if x is None else f"{x:+.{digits}f}"


def _unchanged(line: Mapping[str, Any], metrics: Sequence[str]) -> bool:
    stats = [line.get(m) for m in metrics]
    return all(st is None or st["mean_diff"] is None or abs(st["mean_diff"]) < UNCHANGED_TOL for st in stats)


def wide_table(
    records: Sequence[Mapping[str, Any]], metrics: Sequence[str], *, show_all: bool = False
) -> tuple[list[str], list[list[str]], int]:
    """Header, body and the number of hidden lines: one line per (group, enhancer), one
    ``mean [lo, hi]`` cell per metric; lines where no metric changed (|Δ| < :data:`UNCHANGED_TOL`)
    are hidden unless ``show_all``."""
    keys = [k for k in _LABEL_KEYS if len({str(r[k]) for r in records}) > 1] or ["noise", "snr_db"]
    lines: dict[tuple, dict[str, Any]] = {}
    for r in records:
        line = lines.setdefault((r["enhancer"], *(str(r[k]) for k in keys)), {"r": r, "n": 0})
        line[r["metric"]] = r
        line["n"] = max(line["n"], r["n"])
    header = ["enhancer", *keys, "n seeds", *(f"Δ {m} [95% CI]" for m in metrics)]
    body = []
    hidden = 0
    for line in lines.values():
        if not show_all and _unchanged(line, metrics):
            hidden += 1
            continue
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
    return header, body, hidden


def _cell(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


CSV_COLUMNS = (*_LABEL_KEYS, "enhancer", "metric", "paired", "n", "mean_a", "mean_b", "mean_diff", "sd_diff", "ci_low", "ci_high")


def sweep_differences(store_a, store_b) -> str:
    """One line naming the parameters that differ between the stores' sweeps (A -> B)."""
    from benchmarks.run.versioning import describe_changes, stored_config

    ca, cb = stored_config(store_a), stored_config(store_b)
    if ca is None or cb is None:
        return "unknown (a store records no sweep configuration)"
    return describe_changes(ca, cb, limit=20)


def compare_stores(
    dir_a: str | Path,
    dir_b: str | Path,
    *,
    out_dir: str | Path | None = None,
    metrics: Sequence[str] = DEFAULT_METRICS,
    show_all: bool = False,
) -> tuple[str, list[Path]]:
    """Compare two stores; write ``compare.csv`` (long, every line) and ``compare.md`` (wide)
    to ``out_dir``.

    Returns the Markdown text (also printed by the CLI) and the written paths.  ``out_dir``
    defaults to ``DIR_B/compare``; ``show_all`` keeps the lines where nothing changed.
    """
    from benchmarks.report.splits import split_label
    from benchmarks.report.tables import markdown_table
    from benchmarks.store.sqlite import ResultStore

    with ResultStore.open(dir_a, readonly=True) as sa, ResultStore.open(dir_b, readonly=True) as sb:
        rows_a, rows_b = sa.rows(), sb.rows()
        changes = sweep_differences(sa, sb)
    try:
        records, notes = compare_rows(rows_a, rows_b, metrics=metrics)
    except SweepMismatch as exc:  # say what differs, in the same one line
        raise SweepMismatch(f"{exc}; sweep parameters A -> B: {changes}") from None
    header, body, hidden = wide_table(records, metrics, show_all=show_all)
    paired = all(r["paired"] for r in records)
    how = ("Paired over seeds (B − A per condition), mean and {:.0%} Student-t CI; n = seeds where both rows are ok."
           if paired else "Unpaired: mean of B's seeds − mean of A's seeds, {:.0%} Welch t-CI; n = the smaller "
           "number of seeds.").format(CONFIDENCE)  # fmt: skip
    if hidden:
        notes.append(f"{hidden} line(s) where no metric changed are hidden (--all shows them)")
    text = "\n".join([
        f"# B − A: {dir_b} minus {dir_a}",
        "",
        f"Sweep parameters that differ (A -> B): {changes}.",
        "",
        f"Data of A: {split_label(rows_a)}; of B: {split_label(rows_b)}.",
        "",
        how,
        *(f"- {n}" for n in notes),
        "",
        markdown_table(header, body) if body else "No metric changed.",
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


__all__ = ["DEFAULT_METRICS", "PairedStat", "SweepMismatch", "compare_rows", "compare_stores", "paired_ci",
           "sweep_differences", "welch_ci", "wide_table"]
