"""``scenesim bench report``: Markdown + CSV tables and PNG figures from the results rows.

:func:`write_report` takes the rows of the store's ``results`` table as dicts (contract
columns plus extras such as ``trace_json``) and writes under ``OUT_DIR/report/``
``summary.md`` and ``index.html`` in this order:

* a contents list (in-page links) and the overview figure (:func:`benchmarks.report.figures.overview_figure`);
* a banner when the run is limited or partial (``N of M conditions``) or holds rows of a
  stopped run (:func:`coverage_banner`);
* :data:`HEADLINE_SECTIONS` -- the ranking ("which system, by how much, how sure": one
  system x metric table per noise, letters from Holm-corrected paired tests,
  :mod:`benchmarks.report.ranking`) and the paired verdicts against ``passthrough`` and ``ss``
  (:mod:`benchmarks.report.verdicts`);
* the figures (:mod:`benchmarks.report.figures` and the sections' own), only those the data supports;
* :data:`SECTIONS` -- the details: realistic phones, mismatch, reverberation, the thesis-style
  tables beside the thesis' printed numbers (tables 7.1-7.9) with its headline, RT60 and
  noise-azimuth sweeps, the honesty flags, every condition, failures (latency notes in one
  line), data sources;
* the files: ``verdicts.csv``, ``ranking.csv``, ``thesis_comparison.csv``, ``averages.csv``,
  ``conditions.csv``, sweeps, ``failures.csv`` ... (a CSV without rows is not listed).

Every statistic is a mean over seeds (each drawing its talker, excerpts and, with
tolerances, its phone) shown with its ``n``: one seed gives the value, fewer than
:data:`~benchmarks.report.tables.MIN_T_SEEDS` the seeds' min … max, more a 95 % Student-t
interval clipped to the metric's range (:func:`~benchmarks.report.tables.stat_cell`).  A
spread is never taken over input SNRs.  Conditions that differ only by a value drawn per seed
are one condition.  Long tables are folded (``<details>``); columns equal in every row are
said once below the table.  Rows with ``status = 'error'`` are counted and listed, never
averaged.  Other modules add a section with one line (see :data:`SECTIONS`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.metrics.evaluate import CROSS_WARN_RATIO
from benchmarks.report import figures
from benchmarks.report import measures as report_measures
from benchmarks.report import reverb as report_reverb
from benchmarks.report import sensors as report_sensors
from benchmarks.report import thesis_repro as report_thesis_repro
from benchmarks.report import tradeoff as report_tradeoff
from benchmarks.report.html import slug, write_index
from benchmarks.report.listening import ListenOptions
from benchmarks.report.ranking import active_rule, ranking_section
from benchmarks.report.ratings import ratings_section
from benchmarks.report.splits import captioned, header_line, split_label
from benchmarks.report.tables import (
    CONDITION_KEYS,
    METRIC_FIELDS,
    SMALL_N_TEXT,
    aggregate,
    aggregate_over_seeds,
    constant_columns,
    distinct,
    drawn_keys,
    fmt,
    group_drawn,
    markdown_table,
    normalise_rows,
    num,
    stat_cell,
    sweep_slices,
    write_csv,
)
from benchmarks.report.verdicts import EXTRA_VERDICT_METRICS, verdicts_section
from benchmarks.thesis import reference as T
from benchmarks.thesis.results import find_results

REPORT_DIRNAME = "report"


#: The "All conditions" Markdown table is included up to this many conditions (CSV always).
MAX_MARKDOWN_CONDITIONS = 150
#: Tables with more rows than this are folded (``<details>``) on the page.
FOLD_ROWS = 12

_THESIS_COLS = ("snr_out_db", "snr_i_db", "pesq_in", "pesq_out", "pesq_i")


def _with_std(fields: Sequence[str]) -> list[str]:
    return [c for f in fields for c in (f, f + "_std", f + "_ci95")]


def _label(name: str) -> str:
    system = T.thesis_system(name)
    return f"{system} (`{name}`)" if system else f"`{name}`"


# -- tables --------------------------------------------------------------------------------


def thesis_comparison(ok_rows: Sequence[dict]) -> list[dict[str, Any]]:
    """Per (enhancer, noise, input SNR) at the thesis geometry: our means beside the thesis'."""
    rows = [r for r in ok_rows if T.is_thesis_condition(r)]
    out = aggregate(rows, ("enhancer", "noise", "snr_in_db"))
    for rec in out:
        ref = T.thesis_row(rec["enhancer"], rec["noise"], rec["snr_in_db"])
        rec["thesis_system"] = T.thesis_system(rec["enhancer"])
        rec["thesis_table"] = ref.table if ref else None
        for col in _THESIS_COLS:
            rec["thesis_" + col] = getattr(ref, col) if ref else None
    return sorted(
        out,
        key=lambda r: (
            T.system_rank(r["enhancer"]),
            str(r["enhancer"]),
            r["noise"],
            r["snr_in_db"] if r["snr_in_db"] is not None else math.inf,
        ),
    )


def averages(comparison: Sequence[dict]) -> list[dict[str, Any]]:
    """Mean over input SNRs of the per-SNR means, per (enhancer, noise); the thesis' mean is
    taken over the same input SNRs (those both have)."""
    groups: dict[tuple, list[dict]] = {}
    for rec in comparison:
        groups.setdefault((rec["enhancer"], rec["noise"]), []).append(rec)
    out = []
    for (name, noise), recs in groups.items():
        avg: dict[str, Any] = {
            "enhancer": name,
            "noise": noise,
            "thesis_system": T.thesis_system(name),
            "snr_values_db": " ".join(
                f"{r['snr_in_db']:g}" for r in recs if r["snr_in_db"] is not None
            ),
        }
        for f in ("snr_i_db", "pesq_nb_out", "pesq_wb_out", "pesq_nb_i", "pesq_wb_i", "stoi_out",
                  "pesq_nb_raw_out", "pesq_nb_raw_i"):
            vals = [r[f] for r in recs if r.get(f) is not None]
            avg[f] = sum(vals) / len(vals) if vals else None
        matched = [r for r in recs if r.get("thesis_table")]
        for col in ("snr_i_db", "pesq_out", "pesq_i"):
            vals = [r["thesis_" + col] for r in matched]
            avg["thesis_" + col] = sum(vals) / len(vals) if vals else None
        avg["thesis_n_snr"] = len(matched)
        out.append(avg)
    order = T.system_order(r["enhancer"] for r in out)
    return sorted(out, key=lambda r: (order.index(r["enhancer"]), r["noise"]))


def _sweep(
    ok_rows, vary: str, fixed: tuple[str, ...], prefer: tuple, max_groups: int
) -> tuple[list[dict], list[str]]:
    """Per (enhancer, noise, fixed..., ``vary``) over the sweeps of :func:`sweep_slices`: each
    seed's mean over the common input SNRs, then mean and 95 % CI over seeds; also one line
    per sweep saying what was held fixed.  Rows whose noise azimuth was drawn per seed are
    not an azimuth sweep and are left out."""
    ok_rows = [r for r in ok_rows if "noise_az_deg" not in drawn_keys(r) and r.get(vary) is not None]
    records: list[dict] = []
    notes: list[str] = []
    for sel, base, snrs in sweep_slices(ok_rows, vary, fixed, prefer=prefer, max_groups=max_groups):
        agg = aggregate_over_seeds(sel, ("enhancer", "noise", *fixed, vary))
        agg.sort(key=lambda r: (T.system_rank(r["enhancer"]), str(r["enhancer"]), str(r["noise"])))
        records += agg
        held = ", ".join(f"{k} = {v:g}" for k, v in zip(fixed, base) if num(v) is not None)
        notes.append(f"{held}; input SNR {_snr_text(snrs)}")
    return records, notes


def _snr_text(snrs) -> str:
    return ", ".join(f"{s:g}" for s in snrs) + " dB"


def _failure_label(part: str) -> str:
    head = part.split(":", 1)[0].strip()
    return head if head and " " not in head else "other"


def failures(rows: Sequence[dict]) -> dict[str, Any]:
    """Counts and messages: enhancer failures (status 'error'), metric failures in ok rows,
    latency warnings."""
    errors = [r for r in rows if r["status"] != "ok"]
    by_message = Counter(str(r.get("error") or "(no message)") for r in errors)
    metric = Counter()
    examples: dict[str, str] = {}
    for r in rows:
        if r["status"] == "ok" and r.get("error"):
            for part in str(r["error"]).split("; "):
                label = _failure_label(part)
                metric[label] += 1
                examples.setdefault(label, part)
    latency = [r for r in rows if r.get("latency_check")]
    warned = [r for r in rows if r.get("warnings")]
    suspect = [r for r in rows if abs(num(r.get("snr_cross_ratio")) or 0.0) > CROSS_WARN_RATIO]
    warning_messages = Counter(
        part for r in warned for part in str(r["warnings"]).split("; ") if part.strip()
    )
    return {
        "n_warning_rows": len(warned),
        "snr_suspect": suspect,
        "warning_messages": warning_messages.most_common(),
        "n_error_rows": len(errors),
        "error_messages": by_message.most_common(),
        "error_rows": errors,
        "metric_failures": metric.most_common(),
        "metric_examples": examples,
        "latency_warnings": latency,
    }


# -- Markdown ------------------------------------------------------------------------------


def _cell(rec, f, digits=None):
    return stat_cell(rec, f, digits)


def folded(summary: str, block: Sequence[str], n_rows: int) -> list[str]:
    """``block`` as is, or inside ``<details>`` (closed) when it has more than :data:`FOLD_ROWS` rows.

    >>> folded("T", ["| x |"], 20)[0]
    '<details><summary>T (20 rows)</summary>'
    """
    if n_rows <= FOLD_ROWS:
        return [*block, ""]
    return [f"<details><summary>{summary} ({n_rows} rows)</summary>", "", *block, "", "</details>", ""]


def table_lines(header: Sequence[str], body: Sequence[Sequence[str]], *, keep: int = 1, summary: str = "Table") -> list[str]:
    """A Markdown table without its constant columns (said in one line below it), folded when long.

    >>> table_lines(["a", "n"], [["x", "1"], ["y", "1"]])[-2]
    'Same in every row: n = 1.'
    """
    header, body, notes = constant_columns(header, body, keep=keep)
    block = [markdown_table(header, body)]
    if notes:
        block += ["", "Same in every row: " + "; ".join(notes) + "."]
    return folded(summary, block, len(body))


def _thesis_section(comparison: Sequence[dict]) -> list[str]:
    g = T.THESIS_GEOMETRY
    lines = [
        "## Thesis conditions (ideal sensors: an upper bound)",
        "",
        f"The thesis geometry: anechoic, far field, 2.14 cm pair, speech at "
        f"{g['speech_az_deg']:g}°, one point noise at {g['noise_az_deg']:g}° (broadside), and "
        "**ideal sensors** -- two identical, noiseless microphones. Under these idealised conditions "
        "our EB exceeds the thesis' tables (the SNR-I columns below, ours beside the thesis') while SS "
        "stays close to them; the thesis' own "
        "simulation (preset `thesis-repro`) accounts for most of "
        "the gap, so read the EB rows here as an **upper bound of the method**, not as a reproduction. "
        f"Ours: mean over seeds; {SMALL_N_TEXT} SNR-I = output SNR − input SNR at the "
        "reference mic (replay of the recorded operation on speech and noise). "
        "PESQ *raw* = raw ITU-T P.862 score (−0.5..4.5), the thesis' scale; *nb* = P.862.1 "
        "MOS-LQO; *wb* = P.862.2. `passthrough` is the input and is left out.",
        "",
    ]
    if not comparison:
        return lines + ["No results at the thesis geometry.", ""]
    header = ["SNR in (dB)", "SNR in meas.", "SNR out", "SNR out thesis", "SNR-I", "SNR-I thesis", "PESQ in raw",
              "PESQ in thesis", "PESQ out raw", "PESQ out thesis", "PESQ-I raw", "PESQ-I thesis",
              "PESQ out nb (MOS-LQO)", "PESQ out wb", "n"]  # fmt: skip
    groups: dict[tuple, list[dict]] = {}
    for rec in comparison:
        if T.base_name(rec["enhancer"]) != "passthrough":
            groups.setdefault((rec["enhancer"], rec["noise"]), []).append(rec)
    block: list[str] = []
    for (name, noise), recs in groups.items():
        tables = sorted({r["thesis_table"] for r in recs if r.get("thesis_table")})
        source = f" — thesis table {', '.join(tables)}" if tables else ""
        block += [f"### {_label(name)}, {noise}{source}", ""]
        body = [[fmt(r["snr_in_db"], 0), _cell(r, "snr_in_db_measured"), _cell(r, "snr_out_db"),
                 fmt(r["thesis_snr_out_db"], 1), _cell(r, "snr_i_db"), fmt(r["thesis_snr_i_db"], 1),
                 _cell(r, "pesq_nb_raw_in"), fmt(r["thesis_pesq_in"], 2), _cell(r, "pesq_nb_raw_out"),
                 fmt(r["thesis_pesq_out"], 2), _cell(r, "pesq_nb_raw_i"), fmt(r["thesis_pesq_i"], 2),
                 _cell(r, "pesq_nb_out"), _cell(r, "pesq_wb_out"), str(r["n"])] for r in recs]  # fmt: skip
        block += table_lines(header, body, summary=f"{name}, {noise}")
    n_rows = sum(len(recs) for recs in groups.values())
    return lines + folded(f"Per input SNR, beside the thesis' tables ({len(groups)} tables)", block, n_rows)


def _averages_section(avg: Sequence[dict]) -> list[str]:
    lines = [
        "## Averages over input SNR (thesis geometry, ideal sensors)",
        "",
        "Mean over the input SNRs of the per-SNR means (no spread is taken over SNRs). "
        "PESQ raw = raw P.862, the thesis' scale.",
        "",
    ]
    if not avg:
        return lines + ["No results at the thesis geometry.", ""]
    header = ["system", "noise", "input SNRs (dB)", "SNR-I", "SNR-I thesis", "PESQ out raw", "PESQ out thesis",
              "PESQ-I raw", "PESQ-I thesis", "PESQ nb out (MOS-LQO)", "PESQ wb out", "STOI out"]  # fmt: skip
    body = [[_label(a["enhancer"]), a["noise"], a["snr_values_db"], fmt(a["snr_i_db"], 1), fmt(a["thesis_snr_i_db"], 1),
             fmt(a["pesq_nb_raw_out"]), fmt(a["thesis_pesq_out"]), fmt(a["pesq_nb_raw_i"]), fmt(a["thesis_pesq_i"]),
             fmt(a["pesq_nb_out"]), fmt(a["pesq_wb_out"]), fmt(a["stoi_out"])] for a in avg]  # fmt: skip
    lines += table_lines(header, body, keep=2, summary="Averages")
    ebss = {a["noise"]: a for a in avg if T.base_name(a["enhancer"]) == "eb-ss"}
    noises = [n for n in T.THESIS_NOISES if n in ebss]
    if noises:
        ours = " / ".join(fmt(ebss[n]["snr_i_db"], 1) for n in noises)
        theirs = " / ".join(f"{T.THESIS_HEADLINE_SNR_I_DB[n]:g}" for n in noises)
        tables = " / ".join(fmt(ebss[n]["thesis_snr_i_db"], 1) for n in noises)
        pesq = " / ".join(fmt(ebss[n]["pesq_nb_raw_out"], 2) for n in noises)
        lines += [
            f"**Headline (EB-SS average SNR-I, {' / '.join(noises)}, ideal sensors):** ours "
            f"{ours} dB; thesis {theirs} dB as claimed (its tables average {tables} dB over the "
            f"same input SNRs). Average output PESQ (raw P.862): ours {pesq}; thesis about 3.1.",
            "",
        ]
    if any(T.base_name(a["enhancer"]) in ("eb", "eb-ss") for a in avg):
        lines += report_thesis_repro.reading_the_comparison()
    return lines


_COLUMN_LABELS = {
    "rt60_s": ("RT60 (s)", 2),
    "speech_az_deg": ("speech az (°)", 0),
    "noise_az_deg": ("noise az (°)", 0),
}


def _sweep_section(title: str, agg: Sequence[dict], keys: Sequence[str], notes: Sequence[str]):
    """A sweep table: system, noise, the ``keys`` (fixed ones, then the varied one), metrics."""
    if not agg:
        return []
    header = ["system", "noise", *(_COLUMN_LABELS[k][0] for k in keys), "SNR-I (dB)",
              "PESQ out raw", "PESQ nb out", "PESQ wb out", "STOI out", "n"]  # fmt: skip
    body = [[_label(r["enhancer"]), r["noise"], *(fmt(r[k], _COLUMN_LABELS[k][1]) for k in keys),
             _cell(r, "snr_i_db"), _cell(r, "pesq_nb_raw_out"), _cell(r, "pesq_nb_out"), _cell(r, "pesq_wb_out"),
             _cell(r, "stoi_out"), str(r["n"])] for r in agg]  # fmt: skip
    held = "; ".join(f"({k + 1}) {note}" for k, note in enumerate(notes))
    text = f"Each seed's mean over the input SNRs, then the mean over seeds; {SMALL_N_TEXT} Sweeps shown: {held}."
    return [f"## {title}", "", text, "", *table_lines(header, body, keep=2, summary=title)]


def _conditions_section(cond: Sequence[dict]) -> list[str]:
    lines = [
        "## All conditions",
        "",
        f"{len(cond)} (system, condition) groups; every column in `conditions.csv`. Conditions that "
        "differ only by a value drawn per seed (noise azimuth, talker placement) are one group "
        "(the column says *drawn*).",
        "",
    ]
    if not cond or len(cond) > MAX_MARKDOWN_CONDITIONS:
        return lines
    header = ["system", "noise", "RT60 (s)", "speech °", "noise °", "SNR in", "SNR out", "SNR-I", "PESQ raw in",
              "PESQ raw out", "PESQ wb in", "PESQ wb out", "STOI in", "STOI out", "n"]  # fmt: skip

    def geo(r, k):
        return "drawn" if r.get(k) is None else fmt(r[k], 0)

    body = [[_label(r["enhancer"]), r["noise"], fmt(r["rt60_s"], 2), geo(r, "speech_az_deg"), geo(r, "noise_az_deg"),
             fmt(r["snr_in_db"], 0), _cell(r, "snr_out_db"), _cell(r, "snr_i_db"), _cell(r, "pesq_nb_raw_in"),
             _cell(r, "pesq_nb_raw_out"), _cell(r, "pesq_wb_in"), _cell(r, "pesq_wb_out"), _cell(r, "stoi_in"),
             _cell(r, "stoi_out"), str(r["n"])] for r in cond]  # fmt: skip
    return lines + table_lines(header, body, keep=2, summary="All conditions")


def _short(text: str, limit: int = 300) -> str:
    text = " ".join(str(text).split()).replace("|", "\\|")
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _latency_line(rows: Sequence[dict]) -> str:
    """Latency warnings in one line: counts per system and one example (for `eb` they are an
    expected property: its output is not a pure delay of the reference)."""
    if not rows:
        return "- Latency notes: **0**."
    counts = Counter(str(r.get("enhancer")) for r in rows)
    per = ", ".join(f"{k} {v}" for k, v in sorted(counts.items(), key=lambda kv: (T.system_rank(kv[0]), kv[0])))
    return (f"- Latency notes: **{len(rows)}** ({per}; e.g. {_short(rows[0]['latency_check'], 160)}) -- "
            "expected where a system's output is not a pure delay of the reference (adaptive or "
            "frequency-dependent filters); every row in `failures.csv`.")


def _failures_section(fail: Mapping[str, Any], n_rows: int) -> list[str]:
    lines = [
        "## Failures",
        "",
        f"- Rows with status 'error' (enhancer failed): **{fail['n_error_rows']}** of {n_rows}.",
    ]
    for message, count in fail["error_messages"]:
        lines.append(f"  - {count} × {_short(message)}")
    lines.append(
        f"- Metric failures in 'ok' rows (metric left empty): "
        f"**{sum(c for _, c in fail['metric_failures'])}**."
    )
    for label, count in fail["metric_failures"]:
        lines.append(f"  - `{label}`: {count} × e.g. {_short(fail['metric_examples'][label])}")
    lines.append(_latency_line(fail["latency_warnings"]))
    suspect = fail["snr_suspect"]
    lines.append(
        f"- Rows whose output SNR is suspect (|2<s_out, n_out>| > {CROSS_WARN_RATIO:g} of the "
        f"output power): **{len(suspect)}**."
    )
    for name, count in Counter(str(r.get("enhancer")) for r in suspect).most_common():
        lines.append(f"  - {name}: {count} rows")
    lines.append(
        f"- Rows with Python warnings while rendering/processing: **{fail['n_warning_rows']}**."
    )
    for message, count in fail["warning_messages"][:10]:
        lines.append(f"  - {count} × {_short(message)}")
    return lines + [""]


def _sources_section(rows: Sequence[dict]) -> list[str]:
    counts = Counter((r.get("speech_source") or "?", r.get("noise_source") or "?") for r in rows)
    body = [[_short(s, 120), _short(n, 120), str(c)] for (s, n), c in sorted(counts.items())]
    return ["## Data sources", "", *folded("Data sources", [markdown_table(["speech", "noise", "rows"], body)], len(body))]


def _meta_lines(meta: Mapping[str, Any] | None, rows: Sequence[dict]) -> list[str]:
    n_ok = sum(r["status"] == "ok" for r in rows)
    lines = ["# scenesim benchmark report", ""]
    lines.append(header_line(rows))
    for key, value in (meta or {}).items():
        lines.append(f"- **{key}**: {_short(value, 500)}")
    seeds = distinct(rows, "seed")
    lines += [
        f"- **rows**: {len(rows)} ({n_ok} ok, {len(rows) - n_ok} error); systems: "
        f"{', '.join(T.system_order(r['enhancer'] for r in rows if r.get('enhancer')))}; "
        f"noises: {', '.join(str(n) for n in distinct(rows, 'noise'))}; seeds: {len(seeds)}",
        "",
    ]
    return lines


def contents_lines(lines: Sequence[str]) -> list[str]:
    """An in-page contents list of the ``## `` headings in ``lines`` (anchors by
    :func:`benchmarks.report.html.slug`).

    >>> contents_lines(["## Paired verdicts", "text"])[4]
    '- [Paired verdicts](#paired-verdicts)'
    """
    titles = [ln[3:].strip() for ln in lines if ln.startswith("## ")]
    # folded, so the first screen shows the ranking rather than a list of links
    return ["## Contents", "", f"<details><summary>{len(titles)} sections</summary>", "",
            *(f"- [{t}](#{slug(t)})" for t in titles), "", "</details>", ""]


# -- sections ------------------------------------------------------------------------------


@dataclass
class ReportContext:
    """What every section function sees: the rows (all, ok, generic) and where to write."""

    all_rows: list[dict]
    ok: list[dict]
    fields: list[str]
    generic: list[dict]
    report_dir: Path
    ranking: tuple[str, ...] = ()


Section = Callable[[ReportContext], tuple[list[str], list[Path]]]


def _ranking_part(ctx: ReportContext) -> tuple[list[str], list[Path]]:
    """The ranking by the sweep's rule (headline tables); a row is *flagged* when the honesty
    section flags it or its Hagerman speech leak exceeds its noise term (``hagerman_leak_db > 0``)."""
    flagged = {id(r) for rows in report_sensors.honesty_flags(ctx.ok).values() for r in rows}
    flagged |= {id(r) for r in ctx.ok if (num(r.get("hagerman_leak_db")) or -math.inf) > 0.0}
    return ranking_section(ctx.ok, ctx.report_dir, rule=ctx.ranking or None, flagged=lambda r: id(r) in flagged)


def _verdicts_part(ctx: ReportContext) -> tuple[list[str], list[Path]]:
    """Paired verdicts against the baselines on the ranking rule's metrics, SNR-I, SINR-I, SRMR."""
    rule = active_rule(ctx.ok, ctx.ranking or None)
    return verdicts_section(ctx.ok, ctx.report_dir, metrics=(*rule, *EXTRA_VERDICT_METRICS))


def _phone_part(ctx):
    return report_sensors.phone_section(ctx.ok, ctx.report_dir)


def _mismatch_part(ctx):
    return report_sensors.mismatch_section(ctx.ok, ctx.report_dir)


def _reverb_part(ctx):
    return report_reverb.reverb_sections(ctx.ok, ctx.report_dir)


def _flags_part(ctx):
    return report_sensors.honesty_section(ctx.ok, ctx.report_dir)


def _sources_part(ctx):
    return _sources_section(ctx.all_rows), []


#: The page's sections in order: :data:`HEADLINE_SECTIONS` (the decisions) right after the
#: overview figure, then the figures, then :data:`SECTIONS` (details).  Other modules add a
#: section with one line, e.g. ``SECTIONS.insert(2, my_section)``; a section takes a
#: :class:`ReportContext` and returns ``(markdown lines, written paths)``, its lines starting
#: with a ``## `` heading (the contents list links every one).
HEADLINE_SECTIONS: list[Section] = [_ranking_part, _verdicts_part]
SECTIONS: list[Section] = [
    _phone_part, lambda c: report_tradeoff.tradeoff_section(c.ok, c.report_dir),
    lambda c: report_measures.measures_section(c.ok, c.report_dir), _mismatch_part, _reverb_part, lambda c: _thesis_part(c.ok, c.fields, c.report_dir),
    lambda c: _sweeps_part(c.generic, c.fields, c.report_dir), _flags_part,
    lambda c: _conditions_part(c.ok, c.fields, c.report_dir), lambda c: _failures_part(c.all_rows, c.report_dir),
    ratings_section,
    _sources_part,
]  # fmt: skip


# -- entry point ---------------------------------------------------------------------------


def write_report(
    rows: Iterable[Mapping[str, Any]],
    out_dir,
    *,
    meta: Mapping[str, Any] | None = None,
    listen: ListenOptions | None = None,
    ranking: Sequence[str] = (),
    banner: Sequence[str] = (),
) -> list[Path]:
    """Write the report for ``rows`` under ``out_dir/report/``; returns the written paths.

    The page opens with a contents list and the overview figure, then the
    :data:`HEADLINE_SECTIONS` (paired verdicts and ranking), the figures, the
    :data:`SECTIONS` (details) and the files.

    Parameters
    ----------
    rows : iterable of mappings
        Rows of the ``results`` table (contract columns; extra columns such as
        ``pesq_nb_i``, ``snr_in_db_measured``, ``estoi_out``, ``trace_json`` and
        ``latency_check`` are used when present).
    out_dir : path
        The sweep's output directory (the report goes to its ``report/`` subfolder).
    meta : mapping, optional
        Shown at the top of ``summary.md`` (preset, versions, date, ...).
    listen : ListenOptions, optional
        Conditions given audio players in ``index.html`` (:mod:`benchmarks.report.html`;
        default: a spread over the swept axes, re-rendered from ``out_dir``'s store).
    ranking : sequence of str
        The sweep's ranking rule (``[sweep] ranking``); empty: the field's metrics.
    banner : sequence of str
        Lines shown first, above everything (a limited or partial run, rows of a stopped run).
    """
    report_dir = Path(out_dir) / REPORT_DIRNAME
    report_dir.mkdir(parents=True, exist_ok=True)
    all_rows = normalise_rows(rows)
    ok = [r for r in all_rows if r["status"] == "ok"]
    fields = [f for f in METRIC_FIELDS if any(f in r for r in all_rows)]
    ctx = ReportContext(all_rows, ok, fields, _generic_rows(ok), report_dir, tuple(ranking))

    overview = figures.overview_figure(ok, report_dir)
    parts = [[section(ctx) for section in group] for group in (HEADLINE_SECTIONS, SECTIONS)]
    written = [p for group in parts for _, paths in group for p in paths]
    fig_paths = [p for p in written if p.suffix == ".png"]
    fig_paths += figures.all_figures(ctx.generic, report_dir) if ctx.generic else []
    paths = [p for p in written if p.suffix != ".png"]
    headline, details = ([ln for lines, _ in group for ln in lines] for group in parts)
    label = split_label(all_rows)
    # the decisions first (which system, by how much, how sure), then the overview figure
    top = captioned([*headline, *_overview_lines(overview, label)], label)
    rest = captioned([*_figure_lines(fig_paths, label), *details, *_files_lines(paths)], label)
    warn = [ln for b in banner for ln in (f"**⚠ {b}**", "")]
    lines = [*_meta_lines(meta, all_rows)[:2], *warn, *_meta_lines(meta, all_rows)[2:], *contents_lines([*top, *rest]),
             *top, *rest]
    summary = report_dir / "summary.md"
    summary.write_text("\n".join(lines) + "\n", encoding="utf-8")
    page = write_index(report_dir, summary.read_text(encoding="utf-8"), all_rows, store_dir=Path(out_dir), listen=listen)
    return [summary, *paths, *overview, *fig_paths, *page]


def _generic_rows(ok: Sequence[dict]) -> list[dict]:
    """Rows the generic RT60/azimuth sweeps and figures may use.

    A sensor-mismatch sweep has its own section; averaging its rows over the mismatch values
    into RT60/azimuth sweeps would describe no microphone pair at all.  Reverberation studies
    (rows with a metric target) draw placements per seed and have their own section
    (:mod:`benchmarks.report.reverb`), which names the target.
    """
    generic = [] if report_sensors.mismatch_rows(ok) else ok
    return [r for r in generic if not r.get("metric_target")]


def _conditions_part(ok, fields, report_dir: Path) -> tuple[list[str], list[Path]]:
    """Every (system, condition) group: ``conditions.csv`` and the "All conditions" section."""
    cond = sorted(
        aggregate(group_drawn(ok), CONDITION_KEYS, fields),
        key=lambda r: (T.system_rank(r["enhancer"]), str(r["enhancer"])),  # stable: keeps key order
    )
    path = write_csv(report_dir / "conditions.csv", cond, [*CONDITION_KEYS, "n", *_with_std(fields)])
    return _conditions_section(cond), [path]


_AVERAGES_COLUMNS = ("enhancer", "thesis_system", "noise", "snr_values_db", "snr_i_db", "pesq_nb_raw_out",
                     "pesq_nb_raw_i", "pesq_nb_out", "pesq_wb_out", "pesq_nb_i", "pesq_wb_i", "stoi_out",
                     "thesis_snr_i_db", "thesis_pesq_out", "thesis_pesq_i", "thesis_n_snr")  # fmt: skip


def _thesis_part(ok, fields, report_dir: Path) -> tuple[list[str], list[Path]]:
    """Rows at the thesis' conditions beside its tables: two CSVs and two sections (or a note)."""
    comparison = thesis_comparison([r for r in ok if not report_thesis_repro.is_repro_row(r)])
    # the thesis' own simulation, cell by cell, with the search's results found next to the store
    repro = report_thesis_repro.repro_section(ok, search_results=find_results(report_dir.parent))
    if not comparison:
        if repro:
            return repro, []
        if not ok:
            return [*_thesis_section(comparison), *_averages_section([])], []
        note = ("No rows at the thesis' conditions (far field, 2.14 cm, 45°/270° point noise, anechoic, "
                "ideal sensors): no thesis tables in this report.")  # fmt: skip
        return [note, ""], []
    avg = averages(comparison)
    paths = [
        write_csv(report_dir / "thesis_comparison.csv", comparison,
                  ["enhancer", "thesis_system", "noise", "snr_in_db", "n", *_with_std(fields), "thesis_table",
                   *("thesis_" + c for c in _THESIS_COLS)]),
        write_csv(report_dir / "averages.csv", avg, list(_AVERAGES_COLUMNS)),
    ]  # fmt: skip
    return [*repro, *_thesis_section(comparison), *_averages_section(avg)], paths


def _sweeps_part(generic, fields, report_dir: Path) -> tuple[list[str], list[Path]]:
    """The generic RT60 and noise-azimuth sweeps (tables and CSVs) the rows support."""
    rt60_keys = (*figures.RT60_FIXED, "rt60_s")
    azim_keys = (*figures.AZIMUTH_FIXED, "noise_az_deg")
    rt60, rt60_notes = _sweep(generic, "rt60_s", figures.RT60_FIXED, figures.RT60_PREFER, 1)
    azim, azim_notes = _sweep(
        generic, "noise_az_deg", figures.AZIMUTH_FIXED, figures.AZIMUTH_PREFER, figures.MAX_AZIMUTH_GROUPS
    )
    paths = []
    if rt60:
        cols = ["enhancer", "noise", *rt60_keys, "n", *_with_std(fields)]
        paths.append(write_csv(report_dir / "rt60_sweep.csv", rt60, cols))
    if azim:
        cols = ["enhancer", "noise", *azim_keys, "n", *_with_std(fields)]
        paths.append(write_csv(report_dir / "azimuth_sweep.csv", azim, cols))
    lines = [
        *_sweep_section("Reverberation (RT60 sweep)", rt60, rt60_keys, rt60_notes),
        *_sweep_section("Noise azimuth sweep", azim, azim_keys, azim_notes),
    ]
    return lines, paths


_FAILURE_COLUMNS = ("condition_id", "enhancer", "noise", "snr_in_db", "rt60_s", "noise_az_deg", "seed",
                    "status", "error", "latency_check")  # fmt: skip


def _failures_part(all_rows, report_dir: Path) -> tuple[list[str], list[Path]]:
    """Enhancer and metric failures, latency and SNR warnings: ``failures.csv`` and its section."""
    listed = [r for r in all_rows if r["status"] != "ok" or r.get("error") or r.get("latency_check")]
    paths = [write_csv(report_dir / "failures.csv", listed, list(_FAILURE_COLUMNS))] if listed else []
    return _failures_section(failures(all_rows), len(all_rows)), paths


def _overview_lines(overview: Sequence[Path], label: str) -> list[str]:
    if not overview:
        return []
    return ["## Overview", "", "Each system per noise (one point per system, the seeds' interval as bars); "
            "the verdicts below say which differences are resolved.", "",
            *(f"![{p.stem} ({label})]({p.name})\n" for p in overview)]  # fmt: skip


def _figure_lines(fig_paths: Sequence[Path], label: str) -> list[str]:
    """The figures, each captioned with its name and the rows' split(s)."""
    if not fig_paths:
        return []
    return ["## Figures", "", *(f"![{p.stem} ({label})]({p.name})\n" for p in fig_paths)]


def _files_lines(paths: Sequence[Path]) -> list[str]:
    """The CSV files that hold rows (a header-only file is not listed)."""
    listed = [p for p in paths if p.suffix != ".csv" or _has_rows(p)]
    if not listed:
        return []
    return ["## Files", "", *(f"- [{p.name}]({p.name})" for p in listed), ""]


def _has_rows(path: Path) -> bool:
    with open(path, encoding="utf-8") as fh:
        return sum(1 for _ in zip(range(2), fh)) > 1
