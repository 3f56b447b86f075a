"""Report sections for reverberation studies (issue 10): RT60 and talker-distance sweeps.

Rows that carry ``metric_target`` (the ``reverb`` and ``distance`` presets, or any sweep with
a room or ``reference = "early50"``) were scored against a stated target -- the direct path,
or the direct path + the first ``early_window_ms`` -- and every table header says which.

* :func:`rt60_summary` -- per system and RT60: SINR-I, noise-only SNR-I, DRR and C50 of input
  and output and their gains, SRMR in/out, PESQ/STOI against the target; each seed's mean over
  noises and input SNRs, then mean and 95 % Student-t CI over seeds (placements and phones
  are drawn per seed).
* :func:`distance_summary` -- the same per RT60 and talker distance, with Sabine's critical
  distance and the distance where the measured DRR of the RIR crosses 0 dB.
* :func:`acoustics_summary` -- target against achieved: T30, EDT, DRR and C50 of each
  condition's actual RIR at the reference mic (one value per geometry, not per enhancer).

Each ``*_section`` returns ``(markdown lines, written paths)``; nothing is written when the
rows hold no such data.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

from benchmarks.report.figures import n_words, new_figure, save_figure, system_style  # noqa: E402
from benchmarks.report.tables import (  # noqa: E402
    SMALL_N_TEXT,
    aggregate_over_seeds,
    distinct,
    error_bars,
    fmt,
    markdown_table,
    num,
    stat_cell,
    write_csv,
)
from benchmarks.thesis import reference as T  # noqa: E402

REVERB_FIELDS = ("sinr_i_db", "snr_i_db", "sinr_in_db", "sinr_out_db", "drr_in_db", "drr_out_db", "drr_gain_db",
                 "c50_in_db", "c50_out_db", "c50_gain_db", "srmr_in", "srmr_out", "pesq_nb_raw_out", "stoi_out")  # fmt: skip
ACOUSTIC_FIELDS = ("t30_s", "edt_s", "drr_rir_db", "drr_rir_target_db", "c50_rir_db", "c50_rir_target_db",
                   "critical_distance_m", "t_speech_s", "edt_speech_s", "t_mid_s", "edt_mid_s", "d50_rir",
                   "d50_rir_target", "drr_win_rir_db", "drr_win_rir_target_db")  # fmt: skip
_TABLE_FIELDS = (("sinr_i_db", "SINR-I dB"), ("snr_i_db", "SNR-I (noise only) dB"), ("drr_gain_db", "DRR gain dB"),
                 ("c50_gain_db", "C50 gain dB"), ("srmr_in", "SRMR in"), ("srmr_out", "SRMR out"),
                 ("pesq_nb_raw_out", "PESQ out (raw)"), ("stoi_out", "STOI out"))  # fmt: skip


def reverb_rows(ok: Sequence[dict]) -> list[dict]:
    """Rows scored with a stated target, with the DRR/C50 gains derived (``out - in``)."""
    out = []
    for r in ok:
        if not r.get("metric_target"):
            continue
        row = dict(r)
        for gain, (a, b) in (("drr_gain_db", ("drr_out_db", "drr_in_db")), ("c50_gain_db", ("c50_out_db", "c50_in_db"))):
            va, vb = num(row.get(a)), num(row.get(b))
            row[gain] = None if va is None or vb is None else va - vb
        for k in ("distance_m", "rt60_s"):
            row[k] = num(row.get(k))
        out.append(row)
    return out


def split_studies(rows: Sequence[dict]) -> tuple[list[dict], list[dict]]:
    """``(rt60 study rows, distance study rows)``: rows whose talker distance is on a sweep axis
    (several fixed distances in one sweep version and room) go to the second; distances drawn
    per seed (``distance_range_m``) are placements, not a distance sweep."""
    groups: dict[Any, list[dict]] = {}
    rt60 = []
    for r in rows:
        if T.condition_params(r).get("distance_range_m"):
            rt60.append(r)
        else:
            groups.setdefault((r.get("sweep_version"), T.condition_params(r).get("room")), []).append(r)
    dist = []
    for members in groups.values():
        (dist if len(distinct(members, "distance_m")) > 1 else rt60).extend(members)
    return rt60, dist


def target_text(rows: Sequence[dict]) -> str:
    """What the rows' intrusive metrics compared with, for table headers."""
    labels = sorted({str(r.get("metric_target")) for r in rows})
    words = []
    for lab in labels:
        if lab == "direct":
            words.append("direct path")
        elif lab.startswith("early"):
            words.append(f"direct path + first {lab[5:]} ms")
        else:
            words.append(lab)
    return "target = " + " / ".join(words)


def rt60_summary(rows: Sequence[dict]) -> list[dict[str, Any]]:
    out = aggregate_over_seeds(rows, ("enhancer", "rt60_s"), REVERB_FIELDS)
    order = T.system_order(r["enhancer"] for r in out)
    return sorted(out, key=lambda r: (order.index(r["enhancer"]), r["rt60_s"]))


def distance_summary(rows: Sequence[dict]) -> list[dict[str, Any]]:
    out = aggregate_over_seeds(rows, ("enhancer", "rt60_s", "distance_m"), REVERB_FIELDS)
    order = T.system_order(r["enhancer"] for r in out)
    return sorted(out, key=lambda r: (order.index(r["enhancer"]), r["rt60_s"], r["distance_m"]))


def _one_per_geometry(rows: Sequence[dict]) -> list[dict]:
    seen, out = set(), []
    for r in rows:
        key = r.get("group_id") or r.get("condition_id")
        if key not in seen:
            seen.add(key)
            out.append(r)
    return out


def acoustics_summary(rows: Sequence[dict], by: Sequence[str] = ("rt60_s",)) -> list[dict[str, Any]]:
    """Target against achieved acoustics per ``by``: one RIR per geometry, CI over seeds."""
    geo = [dict(r, enhancer="-") for r in _one_per_geometry(rows)
           if num(r.get("t30_s")) is not None or num(r.get("drr_rir_db")) is not None]  # fmt: skip
    return aggregate_over_seeds(geo, tuple(by), ACOUSTIC_FIELDS)


def drr_zero_crossing_m(distances: Sequence[float], drr_db: Sequence[float]) -> float | None:
    """First distance where DRR falls through 0 dB, interpolated linearly in log distance.

    >>> round(drr_zero_crossing_m([0.5, 1.0, 2.0], [6.0, 2.0, -4.0]), 3)
    1.26
    """
    pts = [(d, v) for d, v in zip(distances, drr_db) if d is not None and v is not None]
    pts.sort()
    for (d0, v0), (d1, v1) in zip(pts, pts[1:]):
        if v0 >= 0.0 > v1:
            f = v0 / (v0 - v1)
            return float(math.exp(math.log(d0) + f * (math.log(d1) - math.log(d0))))
    return None


def _table(recs: Sequence[dict], keys: Sequence[tuple[str, str]]) -> str:
    header = ["system", *(lab for _, lab in keys), "n seeds", *(lab for _, lab in _TABLE_FIELDS)]
    body = [[r["enhancer"], *(f"{r[k]:g}" for k, _ in keys), str(r["n"]),
             *(stat_cell(r, f) for f, _ in _TABLE_FIELDS)] for r in recs]  # fmt: skip
    return markdown_table(header, body)


def _panels(recs, x_key: str, group_key: str | None, xlabel: str, title: str, path: Path, logx: bool) -> Path:
    names = T.system_order(r["enhancer"] for r in recs)
    groups = distinct(recs, group_key) if group_key else [None]
    fig, axes = new_figure(1, 4, figsize=(16, 3.8))
    styles = ("-", "--", ":", "-.")
    specs = (("sinr_i_db", "SINR-I (dB)"), ("drr_gain_db", "DRR gain (dB)"), ("c50_gain_db", "C50 gain (dB)"), ("srmr_out", "SRMR of the output"))
    for ax, (f, label) in zip(axes, specs):
        for name in names:
            for g_i, g in enumerate(groups):
                sel = [r for r in recs if r["enhancer"] == name and (g is None or r[group_key] == g) and r.get(f) is not None]
                if not sel:
                    continue
                xs = [r[x_key] for r in sel]
                ax.errorbar(xs, [r[f] for r in sel], yerr=error_bars(sel, f), capsize=2,
                            color=system_style(name)[0], ls=styles[g_i % 4], marker=system_style(name)[1], ms=3,
                            label=name + (f", {group_key} {g:g}" if g is not None else ""))  # fmt: skip
        if logx:
            from matplotlib.ticker import NullFormatter, ScalarFormatter

            ax.set_xscale("log")
            ax.set_xticks(distinct(recs, x_key))
            ax.xaxis.set_major_formatter(ScalarFormatter())
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set(xlabel=xlabel, ylabel=label)
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=6, loc="best", ncol=2 if len(names) * len(groups) > 6 else 1)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def _achieved_figure(acoustics: Sequence[dict], path: Path) -> Path:
    fig, ax = new_figure(figsize=(4.8, 4.2))
    # The speech-octave means (what the target is) when the rows have them, else broadband.
    t_key, e_key = ("t_speech_s", "edt_speech_s") if any(r.get("t_speech_s") is not None for r in acoustics) \
        else ("t30_s", "edt_s")
    recs = [r for r in acoustics if num(r.get("rt60_s")) and r.get(t_key) is not None]
    xs = [r["rt60_s"] for r in recs]
    for f, marker, label in ((t_key, "o", "T30 (achieved)"), (e_key, "s", "EDT (achieved)")):
        ax.errorbar(xs, [r.get(f) for r in recs], yerr=error_bars(recs, f), fmt=marker, capsize=2, label=label)
    hi = max([*xs, *(r.get(t_key) or 0 for r in recs), *(r.get(e_key) or 0 for r in recs), 0.1]) * 1.1
    ax.plot([0, hi], [0, hi], "k--", lw=0.8, label="target")
    ax.set(xlabel="target RT60 (s)", ylabel="achieved at the reference mic (s)", xlim=(0, hi), ylim=(0, hi))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"RT60: target vs achieved (mean; {n_words([r.get('n') or 0 for r in recs])})", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


_ACOUSTIC_PAIRS = (("t_speech_s", "rt60_target_s", "T30 500-2k s"), ("edt_speech_s", "rt60_target_s", "EDT 500-2k s"),
                   ("t_mid_s", "rt60_target_s", "T_mid s"), ("c50_rir_db", "c50_rir_target_db", "C50 dB"),
                   ("d50_rir", "d50_rir_target", "D50"), ("drr_win_rir_db", "drr_win_rir_target_db", "DRR +-2.5 ms dB"),
                   ("drr_rir_db", "drr_rir_target_db", "DRR exact-image dB"))  # fmt: skip


def _acoustics_table(acoustics: Sequence[dict], keys: Sequence[tuple[str, str]]) -> str:
    """ISO 3382 quantities, each as ``achieved / target`` of the same quantity (Sabine diffuse field)."""
    header = [*(lab for _, lab in keys), "n", *(f"{lab} (achieved / target)" for *_, lab in _ACOUSTIC_PAIRS),
              "T30 broadband s", "r_c m"]  # fmt: skip
    body = []
    for r in acoustics:
        target = r.get("rt60_s")
        cells = []
        for got, want, _ in _ACOUSTIC_PAIRS:
            w = target if want == "rt60_target_s" else r.get(want)
            cells.append(f"{stat_cell(r, got, 2)} / {fmt(w)}")
        body.append([*(f"{r[k]:g}" for k, _ in keys), str(r["n"]), *cells,
                     stat_cell(r, "t30_s", 2), fmt(r.get("critical_distance_m"))])  # fmt: skip
    return markdown_table(header, body)


def rt60_section(rows: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    if not rows or len(distinct(rows, "rt60_s")) < 2:
        return [], []
    summary = rt60_summary(rows)
    acoustics = acoustics_summary(rows, ("rt60_s",))
    cols = ["enhancer", "rt60_s", "n", *(x for f in REVERB_FIELDS for x in (f, f + "_ci95"))]
    paths = [write_csv(report_dir / "reverb_rt60.csv", summary, cols)]
    acols = ["rt60_s", "n", *(x for f in ACOUSTIC_FIELDS for x in (f, f + "_ci95"))]
    paths.append(write_csv(report_dir / "reverb_acoustics.csv", acoustics, acols))
    target = target_text(rows)
    n = n_words([r["n"] for r in summary])
    paths.append(_panels(summary, "rt60_s", None, "RT60 (s)", f"{len(distinct(summary, 'enhancer'))} systems vs RT60 ({target}); mean over noises and SNRs per seed; {n}", report_dir / "reverb_vs_rt60.png", False))
    paths.append(_achieved_figure(acoustics, report_dir / "rt60_achieved.png"))
    lines = ["## Reverberation study: systems vs RT60", "",
             f"Metrics against the **{target}**; late reverberation + noise is the interference of SINR "
             "(`sinr_*_db`), SNR-I counts noise only.  Each seed's mean over noises and input SNRs, then "
             f"the mean over seeds (n = {n}; talker, noise placement and phone drawn per seed); {SMALL_N_TEXT}  "
             "RT60 0 = anechoic free field.", "",
             f"### SINR-I, DRR/C50 gain, SRMR vs RT60 ({target})", "",
             _table(summary, (("rt60_s", "RT60 s"),)), "",
             f"### Room acoustics at the reference mic: target vs achieved ({target})", "",
             "One RIR per geometry (talker placement and room); ISO 3382-1 parameters (scenesim.room.iso3382): "
             "T30/EDT per octave by Schroeder integration from the direct arrival, averaged over 500 Hz-2 kHz "
             "(the quantity the target RT60 is) and over 500 Hz-1 kHz (T_mid); C50/D50 split 50 ms after the "
             "direct arrival; DRR with +-2.5 ms around the direct peak and with the exact order-0 image. "
             "Each beside the same quantity of Sabine's diffuse field at the talker's distance.", "",
             _acoustics_table(acoustics, (("rt60_s", "target RT60 s"),)), ""]  # fmt: skip
    return lines, paths


def distance_section(rows: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    if not rows:
        return [], []
    summary = distance_summary(rows)
    acoustics = acoustics_summary(rows, ("rt60_s", "distance_m"))
    cols = ["enhancer", "rt60_s", "distance_m", "n", *(x for f in REVERB_FIELDS for x in (f, f + "_ci95"))]
    paths = [write_csv(report_dir / "reverb_distance.csv", summary, cols)]
    acols = ["rt60_s", "distance_m", "n", *(x for f in ACOUSTIC_FIELDS for x in (f, f + "_ci95"))]
    paths.append(write_csv(report_dir / "reverb_distance_acoustics.csv", acoustics, acols))
    target = target_text(rows)
    n = n_words([r["n"] for r in summary])
    paths.append(_panels(summary, "distance_m", "rt60_s", "talker distance (m)", f"{len(distinct(summary, 'enhancer'))} systems vs talker distance ({target}); {n}", report_dir / "reverb_vs_distance.png", True))
    crit = []
    for rt in distinct(acoustics, "rt60_s"):
        sel = sorted((r for r in acoustics if r["rt60_s"] == rt), key=lambda r: r["distance_m"])
        rc = next((r.get("critical_distance_m") for r in sel if r.get("critical_distance_m") is not None), None)
        meas = drr_zero_crossing_m([r["distance_m"] for r in sel], [r.get("drr_rir_db") for r in sel])
        pas = [r for r in summary if r["rt60_s"] == rt and r["enhancer"] == "passthrough"]
        sig = drr_zero_crossing_m([r["distance_m"] for r in pas], [r.get("drr_in_db") for r in pas]) if pas else None
        crit.append([f"{rt:g}", fmt(rc), fmt(meas), fmt(sig)])
    lines = ["## Reverberation study: systems vs talker distance", "",
             f"Metrics against the **{target}**; mean over seeds (n = {n}); {SMALL_N_TEXT}", "",
             "### Critical distance", "",
             markdown_table(["RT60 s", "r_c = 0.057 sqrt(V/RT60) m", "RIR DRR = 0 dB at (m)", "input-signal DRR = 0 dB at (m)"], crit), "",
             "(Measured crossings interpolated in log distance between the swept distances; – when DRR does not "
             "cross 0 dB in the range.)", "",
             f"### SINR-I, DRR/C50 gain, SRMR vs distance ({target})", "",
             _table(summary, (("rt60_s", "RT60 s"), ("distance_m", "distance m"))), "",
             f"### Room acoustics vs distance: target vs achieved ({target})", "",
             _acoustics_table(acoustics, (("rt60_s", "target RT60 s"), ("distance_m", "distance m"))), ""]  # fmt: skip
    return lines, paths


def reverb_sections(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    """Both studies' sections from the report's ok rows (nothing without reverberation rows)."""
    rows = reverb_rows(ok)
    rt60_rows, dist_rows = split_studies(rows)
    lines, paths = rt60_section(rt60_rows, report_dir)
    more_lines, more_paths = distance_section(dist_rows, report_dir)
    return lines + more_lines, paths + more_paths


__all__ = [
    "acoustics_summary",
    "distance_section",
    "distance_summary",
    "drr_zero_crossing_m",
    "reverb_rows",
    "reverb_sections",
    "rt60_section",
    "rt60_summary",
    "split_studies",
    "target_text",
]
