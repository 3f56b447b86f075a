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
    if std is None or n < 2:
        return None
    return float(_t975(int(n) - 1) * std / math.sqrt(n))


@functools.lru_cache(maxsize=256)
def _t975(dof: int) -> float:
    """Student-t 0.975 quantile (scipy's ``ppf`` costs ~0.5 ms; a report asks thousands of times)."""
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


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
