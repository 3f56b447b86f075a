"""Plain-Python aggregation of results rows (no pandas): grouping, mean/std over seeds, CSV.

Rows are mappings with the results-store columns (contract.md, "Results store").  Missing
values (``None``, NaN, absent keys) are skipped by every statistic.
"""

from __future__ import annotations

import csv
import functools
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

#: The grouping that identifies a condition apart from seed (and talker).
CONDITION_KEYS: tuple[str, ...] = (
    "enhancer",
    "noise",
    "rt60_s",
    "speech_az_deg",
    "noise_az_deg",
    "snr_in_db",
)

#: Numeric columns summarised in the report (those present in the rows are used).
METRIC_FIELDS: tuple[str, ...] = (
    "snr_in_db_measured",
    "snr_out_db",
    "snr_i_db",
    "snr_i_hagerman_db",
    "snr_in_band_db",
    "snr_out_band_db",
    "snr_i_band_db",
    "snr_out_limit_db",
    "pesq_nb_in",
    "pesq_nb_out",
    "pesq_nb_i",
    "pesq_nb_raw_in",
    "pesq_nb_raw_out",
    "pesq_nb_raw_i",
    "pesq_wb_in",
    "pesq_wb_out",
    "pesq_wb_i",
    "stoi_in",
    "stoi_out",
    "estoi_in",
    "estoi_out",
    "segsnr_in_db",
    "segsnr_out_db",
    "si_sdr_in_db",
    "si_sdr_out_db",
    # DNSMOS P.835, in sweeps that opt in (metrics = ["dnsmos"]); empty columns otherwise.
    "dnsmos_sig_in",
    "dnsmos_sig",
    "dnsmos_bak_in",
    "dnsmos_bak",
    "dnsmos_ovrl_in",
    "dnsmos_ovrl",
)

_DERIVED = {
    "pesq_nb_i": ("pesq_nb_out", "pesq_nb_in"),
    "pesq_nb_raw_i": ("pesq_nb_raw_out", "pesq_nb_raw_in"),
    "pesq_wb_i": ("pesq_wb_out", "pesq_wb_in"),
}


def num(value) -> float | None:
    """``value`` as a finite float, or None (None, NaN, Inf, empty or non-numeric text)."""
    if value is None or isinstance(value, bool):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def normalise_rows(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Copies of the rows with the condition keys as floats and derived deltas filled in."""
    out = []
    for r in rows:
        row = dict(r)
        for key in ("rt60_s", "speech_az_deg", "noise_az_deg", "snr_in_db"):
            row[key] = num(row.get(key))
        if row["rt60_s"] is None:
            row["rt60_s"] = 0.0  # anechoic conditions may store NULL
        for key, (a, b) in _DERIVED.items():
            if num(row.get(key)) is None and num(row.get(a)) is not None:
                vb = num(row.get(b))
                row[key] = None if vb is None else num(row.get(a)) - vb
        row["status"] = row.get("status") or "ok"
        out.append(row)
    return out


def mean_std(values: Iterable[Any]) -> tuple[float | None, float | None, int]:
    """Mean, sample standard deviation (None for fewer than 2 values) and count."""
    xs = [v for v in (num(x) for x in values) if v is not None]
    if not xs:
        return None, None, 0
    m = sum(xs) / len(xs)
    s = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else None
    return m, s, len(xs)


def ci95_halfwidth(std: float | None, n: int) -> float | None:
    """Half-width of the two-sided 95 % Student-t confidence interval of a mean of ``n`` values.

    ``t_{0.975, n-1} * std / sqrt(n)``; None for fewer than 2 values.

    >>> round(ci95_halfwidth(1.0, 5), 4)
    1.2417
    """
    return t_halfwidth(std, n, 0.95)


def t_halfwidth(std: float | None, n: int, confidence: float) -> float | None:
    """Half-width of the two-sided Student-t interval of a mean: ``t_{(1+c)/2, n-1} std / sqrt(n)``.

    The one place the report's t-intervals are computed (tables, paired comparisons, verdicts);
    None for fewer than 2 values.

    >>> round(t_halfwidth(1.0, 5, 0.9), 4)
    0.9534
    """
    if std is None or n < 2:
        return None
    return float(_t_quantile(int(n) - 1, 0.5 + confidence / 2) * std / math.sqrt(n))


@functools.lru_cache(maxsize=256)
def _t_quantile(dof: int, q: float) -> float:
    """Student-t ``q`` quantile (scipy's ``ppf`` costs ~0.5 ms; a report asks thousands of times)."""
    from scipy.special import stdtrit  # = scipy.stats.t.ppf, without importing scipy.stats (~0.9 s)

    return float(stdtrit(dof, q))


def _sort_key(value):
    return (0, value, "") if isinstance(value, (int, float)) else (1, 0.0, str(value))


def aggregate(
    rows: Sequence[Mapping[str, Any]],
    by: Sequence[str],
    fields: Sequence[str] = METRIC_FIELDS,
) -> list[dict[str, Any]]:
    """Group ``rows`` by the ``by`` columns; per field ``<f>`` (mean), ``<f>_std``, ``<f>_ci95``
    (half-width of the 95 % t interval of the mean), plus ``n``.

    ``n`` is the number of rows in the group: with ``by`` every condition key but the seed,
    the spread is over seeds (each seed draws its talker, excerpts and, with tolerances, its
    phone).  Groups are sorted by key.
    """
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault(tuple(row.get(k) for k in by), []).append(row)
    out = []
    for key in sorted(groups, key=lambda k: tuple(_sort_key(v) for v in k)):
        members = groups[key]
        rec: dict[str, Any] = dict(zip(by, key))
        rec["n"] = len(members)
        for f in fields:
            m, s, k = mean_std(r.get(f) for r in members)
            rec[f] = m
            rec[f + "_std"] = s
            rec[f + "_ci95"] = ci95_halfwidth(s, k)
            if m is not None:  # for the small-n display (stat_cell)
                vals = [v for v in (num(r.get(f)) for r in members) if v is not None]
                rec[f + "_min"], rec[f + "_max"], rec[f + "_n"] = min(vals), max(vals), k
        out.append(rec)
    return out


def aggregate_over_seeds(
    rows: Sequence[Mapping[str, Any]],
    by: Sequence[str],
    fields: Sequence[str] = METRIC_FIELDS,
) -> list[dict[str, Any]]:
    """Like :func:`aggregate`, but the spread is over seeds only.

    First each seed's mean over everything not in ``by`` (e.g. the input SNRs of a sweep),
    then mean, ``_std`` and ``_ci95`` of those per-seed means; ``n`` is the number of seeds.
    A statistic is never taken over input SNRs or other conditions.
    """
    per_seed = aggregate(rows, (*by, "seed"), fields)
    return aggregate(per_seed, by, fields)


def distinct(rows: Iterable[Mapping[str, Any]], key: str) -> list:
    """Sorted distinct non-None values of ``key``."""
    return sorted({r.get(key) for r in rows if r.get(key) is not None}, key=_sort_key)


def modal(rows: Sequence[Mapping[str, Any]], keys: Sequence[str]) -> tuple | None:
    """The most common combination of ``keys`` (ties: the smallest), or None without rows."""
    counts: dict[tuple, int] = {}
    for r in rows:
        k = tuple(r.get(x) for x in keys)
        counts[k] = counts.get(k, 0) + 1
    if not counts:
        return None
    return min(counts, key=lambda k: (-counts[k], tuple(_sort_key(v) for v in k)))


def sweep_slices(
    rows: Sequence[Mapping[str, Any]],
    vary: str,
    fixed: Sequence[str],
    *,
    prefer: tuple | None = None,
    max_groups: int = 1,
) -> list[tuple[list[Mapping[str, Any]], tuple, list]]:
    """The one-parameter sweeps over ``vary`` in ``rows``, comparable across its values.

    Rows are grouped by the ``fixed`` columns; a group is a sweep when ``vary`` takes at
    least two values in it.  Groups are ranked by the number of distinct ``vary`` values,
    then the ``prefer`` key first (e.g. the thesis geometry), then more rows, then the
    smallest key; at most ``max_groups`` are returned.  In each, only the input SNRs
    present at every value of ``vary`` are kept (all if none is common), so that averaging
    over SNR never mixes different SNR sets.

    Returns
    -------
    list of (rows, fixed_values, snrs)
    """
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in fixed), []).append(r)
    swept = [k for k in groups if len(distinct(groups[k], vary)) >= 2]
    swept.sort(
        key=lambda k: (
            -len(distinct(groups[k], vary)),
            k != prefer,
            -len(groups[k]),
            tuple(_sort_key(v) for v in k),
        )
    )
    out = []
    for key in swept[:max_groups]:
        sel = groups[key]
        values = distinct(sel, vary)
        snr_sets = [
            set(distinct([r for r in sel if r.get(vary) == v], "snr_in_db")) for v in values
        ]
        common = set.intersection(*snr_sets) or set.union(*snr_sets)
        out.append(([r for r in sel if r.get("snr_in_db") in common], key, sorted(common)))
    return out


def write_csv(path: Path, records: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> Path:
    """Write ``records`` (missing values empty) with a header of ``columns``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        for rec in records:
            writer.writerow(["" if rec.get(c) is None else rec.get(c) for c in columns])
    return path


def fmt(value, digits: int = 2, std=None) -> str:
    """``12.35`` or ``12.35 ± 0.40``; an en dash for a missing value."""
    v = num(value)
    if v is None:
        return "–"
    text = f"{v:.{digits}f}"
    if float(text) == 0.0:
        text = f"{0.0:.{digits}f}"  # no "-0.00"
    s = num(std)
    return f"{text} ± {s:.{digits}f}" if s is not None else text


def markdown_table(header: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    """A GitHub-flavoured Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)


#: Below this many seeds a cell shows the seeds' min–max, not a t-interval (t_{0.975, n-1} is
#: 12.7 at n = 2 and 4.3 at n = 3: such intervals say more about t than about the system).
MIN_T_SEEDS = 5

#: How a table cell's spread reads (for the sections' explanations).
SMALL_N_TEXT = (f"n = 1: the value; n < {MIN_T_SEEDS}: mean (seeds' min … max); otherwise mean ± half-width of the "
                "95 % Student-t interval over seeds, or mean [lo, hi]* when it is clipped to the metric's range.")

#: Condition columns that a sweep may draw per seed (from ``*_range_*`` parameters) rather than sweep.
DRAWN_KEYS = {"noise_az_deg": "noise_az_range_deg", "speech_az_deg": "speech_az_range_deg",
              "distance_m": "distance_range_m"}  # fmt: skip


def drawn_keys(row: Mapping[str, Any]) -> list[str]:
    """The row's condition columns whose value was drawn per seed (its ``condition_json`` has the range).

    >>> drawn_keys({"condition_json": '{"noise_az_range_deg": [100, 260]}'})
    ['noise_az_deg']
    """
    text = str(row.get("condition_json") or "")
    return [k for k, rng in DRAWN_KEYS.items() if f'"{rng}"' in text]


def group_drawn(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Copies of ``rows`` with drawn-per-seed condition columns set to None, so the seeds of one
    condition group together instead of one group per draw.

    >>> group_drawn([{"noise_az_deg": 141.3, "condition_json": '{"noise_az_range_deg": [100, 260]}'}])[0]["noise_az_deg"] is None
    True
    """
    return [{**r, **dict.fromkeys(drawn_keys(r))} for r in rows]


#: The physical range of a metric family (prefix of the column name); improvements (``*_i``)
#: span the range's width either way.  Intervals are clipped to it and marked.
METRIC_RANGES: dict[str, tuple[float, float]] = {
    "pesq_nb_raw": (-0.5, 4.5),
    "pesq_nb": (1.0, 4.5),
    "pesq_wb": (1.0, 4.64),
    "stoi": (0.0, 1.0),
    "estoi": (0.0, 1.0),
}


def metric_range(field: str) -> tuple[float, float] | None:
    """The range a mean of ``field`` can take (None: unbounded, e.g. dB).

    >>> metric_range("pesq_nb_raw_out"), metric_range("stoi_i"), metric_range("snr_i_db")
    ((-0.5, 4.5), (-1.0, 1.0), None)
    """
    for prefix in sorted(METRIC_RANGES, key=len, reverse=True):
        if field.startswith(prefix + "_"):
            lo, hi = METRIC_RANGES[prefix]
            return (lo - hi, hi - lo) if field.endswith("_i") else (lo, hi)
    return None


def digits_for(field: str) -> int:
    """Decimals shown for ``field``: one for dB, two otherwise.

    >>> digits_for("snr_i_db"), digits_for("pesq_nb_raw_out")
    (1, 2)
    """
    return 1 if field.endswith("_db") or "_db_" in field else 2


def stat_cell(rec: Mapping[str, Any], field: str, digits: int | None = None) -> str:
    """One table cell for ``field`` of an :func:`aggregate` record, honest about n.

    n = 1: the value; 2 <= n < :data:`MIN_T_SEEDS`: ``mean (min … max)`` over the seeds;
    otherwise ``mean ± half-width`` of the 95 % t-interval, or ``mean [lo, hi]*`` when the
    interval leaves the metric's range and is clipped to it.

    >>> stat_cell({"x_db": 2.0, "x_db_n": 3, "x_db_min": 1.0, "x_db_max": 3.5}, "x_db")
    '2.0 (1.0 … 3.5)'
    >>> stat_cell({"stoi_out": 0.9, "stoi_out_n": 6, "stoi_out_ci95": 0.2}, "stoi_out")
    '0.90 [0.70, 1.00]*'
    """
    digits = digits_for(field) if digits is None else digits
    mean = num(rec.get(field))
    if mean is None:
        return "–"
    n = rec.get(field + "_n") or 1
    lo, hi = rec_interval(rec, field)
    if n < 2 or fmt(lo, digits) == fmt(hi, digits):  # one seed, or seeds that agree to the digits shown
        return fmt(mean, digits)
    if n < MIN_T_SEEDS:
        return f"{fmt(mean, digits)} ({fmt(lo, digits)} … {fmt(hi, digits)})"
    half = num(rec.get(field + "_ci95")) or 0.0
    if math.isclose(lo, mean - half) and math.isclose(hi, mean + half):
        return fmt(mean, digits, half)
    return f"{fmt(mean, digits)} [{fmt(lo, digits)}, {fmt(hi, digits)}]*"


def rec_interval(rec: Mapping[str, Any], field: str) -> tuple[float, float] | None:
    """``(lo, hi)`` an :func:`aggregate` record's cell shows (:func:`stat_cell`): the seeds' min–max
    below :data:`MIN_T_SEEDS`, else the clipped t-interval; None without a value.

    >>> rec_interval({"stoi_out": 0.9, "stoi_out_n": 6, "stoi_out_ci95": 0.2}, "stoi_out")
    (0.7, 1.0)
    """
    mean = num(rec.get(field))
    if mean is None:
        return None
    n = rec.get(field + "_n") or 1
    if n < 2:
        return mean, mean
    if n < MIN_T_SEEDS:
        return rec[field + "_min"], rec[field + "_max"]
    half = num(rec.get(field + "_ci95")) or 0.0
    return clip_interval(field, mean - half, mean + half)


def error_bars(recs: Sequence[Mapping[str, Any]], field: str) -> list[list[float]]:
    """Matplotlib's asymmetric ``yerr`` for ``recs`` (see :func:`rec_interval`); 0 where missing.

    >>> error_bars([{"x": 2.0, "x_n": 2, "x_min": 1.0, "x_max": 2.5}], "x")
    [[1.0], [0.5]]
    """
    lo, hi = [], []
    for r in recs:
        iv, m = rec_interval(r, field), num(r.get(field))
        lo.append(0.0 if iv is None else max(0.0, m - iv[0]))
        hi.append(0.0 if iv is None else max(0.0, iv[1] - m))
    return [lo, hi]


def clip_interval(field: str, lo: float, hi: float) -> tuple[float, float]:
    """``(lo, hi)`` clipped to :func:`metric_range` of ``field`` (unchanged when unbounded)."""
    rng = metric_range(field)
    if rng is None:
        return lo, hi
    return max(lo, rng[0]), min(hi, rng[1])


def constant_columns(header: Sequence[str], body: Sequence[Sequence[str]], keep: int = 1) -> tuple[list[str], list[list[str]], list[str]]:
    """Drop columns (after the first ``keep``) whose cells are all equal; ``(header, body, notes)``
    where each note says ``"column = value"`` for a dropped column, so nothing is lost.

    >>> constant_columns(["a", "n"], [["x", "1"], ["y", "1"]])
    (['a'], [['x'], ['y']], ['n = 1'])
    """
    if len(body) < 2:
        return list(header), [list(r) for r in body], []
    drop = [j for j in range(keep, len(header)) if len({str(r[j]) for r in body}) == 1]
    notes = [f"{header[j]} = {body[0][j]}" for j in drop]
    cols = [j for j in range(len(header)) if j not in drop]
    return [header[j] for j in cols], [[r[j] for j in cols] for r in body], notes


def seed_means(rows: Iterable[Mapping[str, Any]], field: str) -> list[float]:
    """Each seed's mean of ``field`` over its rows (seeds in first-seen order).

    >>> seed_means([{"seed": 0, "x": 1.0}, {"seed": 0, "x": 3.0}, {"seed": 1, "x": 5.0}], "x")
    [2.0, 5.0]
    """
    by_seed: dict[Any, list[float]] = {}
    for r in rows:
        v = num(r.get(field))
        if v is not None:
            by_seed.setdefault(r.get("seed"), []).append(v)
    return [sum(v) / len(v) for v in by_seed.values()]


def seed_interval(values: Sequence[float], field: str) -> tuple[float | None, float | None, float | None]:
    """``(mean, lo, hi)`` of per-seed values: the 95 % t-interval clipped to the metric's range
    for n >= :data:`MIN_T_SEEDS`, else the seeds' min and max (one seed: lo = hi = mean).

    >>> seed_interval([1.0, 2.0, 3.0], "snr_i_db")
    (2.0, 1.0, 3.0)
    """
    m, sd, n = mean_std(values)
    if m is None:
        return None, None, None
    if n < MIN_T_SEEDS:
        return m, min(values), max(values)
    half = ci95_halfwidth(sd, n) or 0.0
    lo, hi = clip_interval(field, m - half, m + half)
    return m, lo, hi


def interval_clipped(values: Sequence[float], field: str) -> bool:
    """True when :func:`seed_interval` of ``values`` had to clip the t-interval to the range.

    >>> interval_clipped([0.99, 0.2, 0.99, 0.99, 0.99], "stoi_out"), interval_clipped([1.0, 3.0], "stoi_out")
    (True, False)
    """
    m, sd, n = mean_std(values)
    if m is None or n < MIN_T_SEEDS:
        return False
    half = ci95_halfwidth(sd, n) or 0.0
    return clip_interval(field, m - half, m + half) != (m - half, m + half)
