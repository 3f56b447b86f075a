"""``scenesim bench report``: Markdown + CSV tables and PNG figures from the results rows.

:func:`write_report` takes the rows of the store's ``results`` table as dicts (contract
columns plus extras such as ``trace_json``) and writes under ``OUT_DIR/report/``:

* ``summary.md`` -- the thesis-style tables (input SNR, output SNR, SNR-I, input/output
  PESQ and PESQ-I, narrow- and wide-band) per system and noise at the thesis geometry,
  beside the thesis' printed numbers (tables 7.1-7.9) where the condition matches;
  averages over input SNR per system and noise with the thesis headline (EB-SS average
  SNR-I 17 / 22 / 18 dB); RT60 and noise-azimuth sweep tables when the rows hold them;
  failures with their messages; the data sources;
* ``thesis_comparison.csv``, ``averages.csv``, ``conditions.csv`` (every condition),
  ``rt60_sweep.csv`` / ``azimuth_sweep.csv`` when present, ``failures.csv``;
* PNG figures (:mod:`benchmarks.figures`), only those the data supports.

Every statistic is the mean over the rows of a condition -- the seeds, each drawing its
talker, excerpts and (with tolerances) its phone -- shown as ``mean ± half-width of the
95 % Student-t confidence interval`` when there is more than one seed, with ``n`` seeds.  A
spread is never taken over input SNRs.  Rows with ``status = 'error'`` are counted and
listed, never averaged.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks import figures, report_reverb, report_sensors, report_thesis_repro
from benchmarks import thesis_reference as T
from benchmarks.evaluate import CROSS_WARN_RATIO
from benchmarks.html_report import write_index
from benchmarks.listening import ListenOptions
from benchmarks.report_tables import (
    CONDITION_KEYS,
    METRIC_FIELDS,
    aggregate,
    aggregate_over_seeds,
    distinct,
    fmt,
    markdown_table,
    normalise_rows,
    num,
    sweep_slices,
    write_csv,
)

REPORT_DIRNAME = "report"


#: The "All conditions" Markdown table is included up to this many conditions (CSV always).
MAX_MARKDOWN_CONDITIONS = 150

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
    ok_rows = [r for r in ok_rows if not _drawn_azimuth(r) and r.get(vary) is not None]
    records: list[dict] = []
    notes: list[str] = []
    for sel, base, snrs in sweep_slices(ok_rows, vary, fixed, prefer=prefer, max_groups=max_groups):
        agg = aggregate_over_seeds(sel, ("enhancer", "noise", *fixed, vary))
        agg.sort(key=lambda r: (T.system_rank(r["enhancer"]), str(r["enhancer"]), str(r["noise"])))
        records += agg
        held = ", ".join(f"{k} = {v:g}" for k, v in zip(fixed, base) if num(v) is not None)
        notes.append(f"{held}; input SNR {_snr_text(snrs)}")
    return records, notes


def _drawn_azimuth(row: dict) -> bool:
    return '"noise_az_range_deg"' in str(row.get("condition_json") or "")


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


def _pm(rec, f, digits=2):
    return fmt(rec.get(f), digits, rec.get(f + "_ci95"))


def _thesis_section(comparison: Sequence[dict]) -> list[str]:
    g = T.THESIS_GEOMETRY
    lines = [
        "## Thesis conditions (ideal sensors: an upper bound)",
        "",
        f"The thesis geometry: anechoic, far field, 2.14 cm pair, speech at "
        f"{g['speech_az_deg']:g}°, one point noise at {g['noise_az_deg']:g}° (broadside), and "
        "**ideal sensors** -- two identical, noiseless microphones. A broadside plane wave then "
        "reaches both mics bit-identically, and a differential pair with beta = 1 (a dipole) "
        "nulls it exactly at every frequency, so the EB numbers below are an **ideal-sensor "
        "upper bound** no phone attains: a 0.5 dB / 2° mismatch between the mics leaves that null "
        "only ~23 dB below the look direction, and self-noise bounds the output SNR (see the `phone` and "
        "`mismatch` presets for real microphones). "
        "Ours: mean ± 95 % CI over seeds (n seeds). SNR-I = output SNR − input SNR at the "
        "reference mic (replay of the recorded operation on speech and noise). "
        "PESQ: *raw* = raw ITU-T P.862 score (−0.5..4.5), the scale the thesis' text describes "
        "and the one compared with its tables; *nb* = the `pesq` package's narrow-band "
        "P.862.1 MOS-LQO; *wb* = P.862.2.",
        "",
    ]
    if not comparison:
        return lines + ["No results at the thesis geometry.", ""]
    header = [
        "SNR in (dB)", "SNR in meas.", "SNR out", "SNR out thesis", "SNR-I", "SNR-I thesis",
        "PESQ in raw", "PESQ in thesis", "PESQ out raw", "PESQ out thesis", "PESQ-I raw",
        "PESQ-I thesis", "PESQ out nb (MOS-LQO)", "PESQ out wb", "n",
    ]  # fmt: skip
    groups: dict[tuple, list[dict]] = {}
    for rec in comparison:
        groups.setdefault((rec["enhancer"], rec["noise"]), []).append(rec)
    for (name, noise), recs in groups.items():
        tables = sorted({r["thesis_table"] for r in recs if r.get("thesis_table")})
        source = f" — thesis table {', '.join(tables)}" if tables else ""
        lines += [f"### {_label(name)}, {noise}{source}", ""]
        body = [
            [
                fmt(r["snr_in_db"], 0),
                _pm(r, "snr_in_db_measured"),
                _pm(r, "snr_out_db"),
                fmt(r["thesis_snr_out_db"]),
                _pm(r, "snr_i_db"),
                fmt(r["thesis_snr_i_db"]),
                _pm(r, "pesq_nb_raw_in", 3),
                fmt(r["thesis_pesq_in"], 3),
                _pm(r, "pesq_nb_raw_out", 3),
                fmt(r["thesis_pesq_out"], 3),
                _pm(r, "pesq_nb_raw_i", 3),
                fmt(r["thesis_pesq_i"], 3),
                _pm(r, "pesq_nb_out", 3),
                _pm(r, "pesq_wb_out", 3),
                str(r["n"]),
            ]  # fmt: skip
            for r in recs
        ]
        lines += [markdown_table(header, body), ""]
    return lines


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
    header = [
        "system", "noise", "input SNRs (dB)", "SNR-I", "SNR-I thesis", "PESQ out raw",
        "PESQ out thesis", "PESQ-I raw", "PESQ-I thesis", "PESQ nb out (MOS-LQO)", "PESQ wb out",
        "STOI out",
    ]  # fmt: skip
    body = [
        [
            _label(a["enhancer"]),
            a["noise"],
            a["snr_values_db"],
            fmt(a["snr_i_db"]),
            fmt(a["thesis_snr_i_db"]),
            fmt(a["pesq_nb_raw_out"], 3),
            fmt(a["thesis_pesq_out"], 3),
            fmt(a["pesq_nb_raw_i"], 3),
            fmt(a["thesis_pesq_i"], 3),
            fmt(a["pesq_nb_out"], 3),
            fmt(a["pesq_wb_out"], 3),
            fmt(a["stoi_out"], 3),
        ]  # fmt: skip
        for a in avg
    ]
    lines += [markdown_table(header, body), ""]
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
    "rt60_s": ("RT60 (s)", 3),
    "speech_az_deg": ("speech az (°)", 0),
    "noise_az_deg": ("noise az (°)", 0),
}


def _sweep_section(title: str, agg: Sequence[dict], keys: Sequence[str], notes: Sequence[str]):
    """A sweep table: system, noise, the ``keys`` (fixed ones, then the varied one), metrics."""
    if not agg:
        return []
    header = ["system", "noise", *(_COLUMN_LABELS[k][0] for k in keys), "SNR-I (dB)",
              "PESQ nb out", "PESQ wb out", "PESQ-I nb", "STOI out", "n"]  # fmt: skip
    body = [
        [
            _label(r["enhancer"]),
            r["noise"],
            *(fmt(r[k], _COLUMN_LABELS[k][1]) for k in keys),
            _pm(r, "snr_i_db"),
            _pm(r, "pesq_nb_out", 3),
            _pm(r, "pesq_wb_out", 3),
            _pm(r, "pesq_nb_i", 3),
            _pm(r, "stoi_out", 3),
            str(r["n"]),
        ]
        for r in agg
    ]
    held = "; ".join(f"({k + 1}) {note}" for k, note in enumerate(notes))
    text = (f"Each seed's mean over the input SNRs, then mean ± 95 % CI over seeds (n seeds). "
            f"Sweeps shown: {held}.")
    return [f"## {title}", "", text, "", markdown_table(header, body), ""]


def _conditions_section(cond: Sequence[dict]) -> list[str]:
    lines = [
        "## All conditions",
        "",
        f"{len(cond)} (system, condition) groups; every column in `conditions.csv`.",
        "",
    ]
    if not cond or len(cond) > MAX_MARKDOWN_CONDITIONS:
        return lines
    header = ["system", "noise", "RT60 (s)", "speech °", "noise °", "SNR in", "SNR out", "SNR-I",
              "PESQ nb in", "PESQ nb out", "PESQ wb in", "PESQ wb out", "STOI in", "STOI out",
              "n"]  # fmt: skip
    body = [
        [
            _label(r["enhancer"]),
            r["noise"],
            fmt(r["rt60_s"], 3),
            fmt(r["speech_az_deg"], 0),
            fmt(r["noise_az_deg"], 0),
            fmt(r["snr_in_db"], 0),
            _pm(r, "snr_out_db"),
            _pm(r, "snr_i_db"),
            _pm(r, "pesq_nb_in", 3),
            _pm(r, "pesq_nb_out", 3),
            _pm(r, "pesq_wb_in", 3),
            _pm(r, "pesq_wb_out", 3),
            _pm(r, "stoi_in", 3),
            _pm(r, "stoi_out", 3),
            str(r["n"]),
        ]  # fmt: skip
        for r in cond
    ]
    return lines + [markdown_table(header, body), ""]


def _short(text: str, limit: int = 300) -> str:
    text = " ".join(str(text).split()).replace("|", "\\|")
    return text if len(text) <= limit else text[: limit - 1] + "…"


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
    lines.append(f"- Latency warnings: **{len(fail['latency_warnings'])}**.")
    for r in fail["latency_warnings"][:10]:
        lines.append(
            f"  - {r.get('enhancer')} / {r.get('condition_id')}: {_short(r['latency_check'])}"
        )
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
    return ["## Data sources", "", markdown_table(["speech", "noise", "rows"], body), ""]


def _meta_lines(meta: Mapping[str, Any] | None, rows: Sequence[dict]) -> list[str]:
    n_ok = sum(r["status"] == "ok" for r in rows)
    lines = ["# scenesim benchmark report", ""]
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


# -- entry point ---------------------------------------------------------------------------


def write_report(
    rows: Iterable[Mapping[str, Any]],
    out_dir,
    *,
    meta: Mapping[str, Any] | None = None,
    listen: ListenOptions | None = None,
) -> list[Path]:
    """Write the report for ``rows`` under ``out_dir/report/``; returns the written paths.

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
        Conditions given audio players in ``index.html`` (:mod:`benchmarks.html_report`;
        default: a spread of noises and input SNRs, re-rendered from ``out_dir``'s store).
    """
    report_dir = Path(out_dir) / REPORT_DIRNAME
    report_dir.mkdir(parents=True, exist_ok=True)
    all_rows = normalise_rows(rows)
    ok = [r for r in all_rows if r["status"] == "ok"]
    fields = [f for f in METRIC_FIELDS if any(f in r for r in all_rows)]
    generic = _generic_rows(ok)

    cond_lines, cond_paths = _conditions_part(ok, fields, report_dir)
    thesis_lines, thesis_paths = _thesis_part(ok, fields, report_dir)
    sweep_lines, sweep_paths = _sweeps_part(generic, fields, report_dir)
    fail_lines, fail_paths = _failures_part(all_rows, report_dir)
    phone_lines, phone_paths = report_sensors.phone_section(ok, report_dir)
    mismatch_lines, mismatch_paths = report_sensors.mismatch_section(ok, report_dir)
    flag_lines, flag_paths = report_sensors.honesty_section(ok, report_dir)
    reverb_lines, reverb_paths = report_reverb.reverb_sections(ok, report_dir)
    written = [*cond_paths, *thesis_paths, *sweep_paths, *fail_paths, *phone_paths, *mismatch_paths,
               *flag_paths, *reverb_paths]  # fmt: skip
    fig_paths = figures.all_figures(generic, report_dir) if generic else []
    fig_paths += [p for p in written if p.suffix == ".png"]
    paths = [p for p in written if p.suffix != ".png"]

    lines = [
        *_meta_lines(meta, all_rows), *phone_lines, *mismatch_lines, *reverb_lines, *thesis_lines,
        *sweep_lines, *cond_lines, *flag_lines, *fail_lines, *_sources_section(all_rows),
        *_files_lines(paths, fig_paths),
    ]  # fmt: skip
    summary = report_dir / "summary.md"
    summary.write_text("\n".join(lines) + "\n", encoding="utf-8")
    page = write_index(report_dir, summary.read_text(encoding="utf-8"), all_rows, store_dir=Path(out_dir), listen=listen)
    return [summary, *paths, *fig_paths, *page]


def _generic_rows(ok: Sequence[dict]) -> list[dict]:
    """Rows the generic RT60/azimuth sweeps and figures may use.

    A sensor-mismatch sweep has its own section; averaging its rows over the mismatch values
    into RT60/azimuth sweeps would describe no microphone pair at all.  Reverberation studies
    (rows with a metric target) draw placements per seed and have their own section
    (:mod:`benchmarks.report_reverb`), which names the target.
    """
    generic = [] if report_sensors.mismatch_rows(ok) else ok
    return [r for r in generic if not r.get("metric_target")]


def _conditions_part(ok, fields, report_dir: Path) -> tuple[list[str], list[Path]]:
    """Every (system, condition) group: ``conditions.csv`` and the "All conditions" section."""
    cond = sorted(
        aggregate(ok, CONDITION_KEYS, fields),
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
    repro = report_thesis_repro.repro_section(ok)  # the thesis' own simulation, cell by cell
    avg = averages(comparison)
    paths = [
        write_csv(report_dir / "thesis_comparison.csv", comparison,
                  ["enhancer", "thesis_system", "noise", "snr_in_db", "n", *_with_std(fields), "thesis_table",
                   *("thesis_" + c for c in _THESIS_COLS)]),
        write_csv(report_dir / "averages.csv", avg, list(_AVERAGES_COLUMNS)),
    ]  # fmt: skip
    if repro and not comparison:
        return repro, paths
    if comparison or not ok:
        return [*repro, *_thesis_section(comparison), *_averages_section(avg)], paths
    note = ("No rows at the thesis' conditions (far field, 2.14 cm, 45°/270° point noise, anechoic, "
            "ideal sensors): no thesis tables in this report.")  # fmt: skip
    return [note, ""], paths


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
    path = write_csv(report_dir / "failures.csv", listed, list(_FAILURE_COLUMNS))
    return _failures_section(failures(all_rows), len(all_rows)), [path]


def _files_lines(paths: Sequence[Path], fig_paths: Sequence[Path]) -> list[str]:
    lines = ["## Files", "", *(f"- `{p.name}`" for p in [*paths, *fig_paths])]
    if fig_paths:
        lines += ["", "## Figures", "", *(f"![{p.stem}]({p.name})\n" for p in fig_paths)]
    return lines
