"""Report sections for real microphones (issue 8): phones drawn per seed, mismatch sweeps, flags.

* :func:`phone_summary` -- per system and noise: the mean over input SNRs of each seed's
  results, then mean and 95 % Student-t CI **over seeds** (each seed one phone, one talker,
  one set of excerpts), beside the thesis' printed averages; the CI is never over SNRs.
* :func:`mismatch_summary` -- SNR-I and PESQ per nominal gain x phase mismatch x self-noise
  x noise geometry.
* :func:`honesty_flags` -- rows whose replay and phase-inversion SNR-I differ by more than
  :data:`HAGERMAN_FLAG_DB`; output SNRs above the self-noise bound; ideal-sensor output SNRs
  above :data:`IDEAL_SNR_FLAG_DB` that no microphone could deliver.

Each ``*_section`` returns ``(markdown lines, written paths)``; nothing is written when the
rows hold no such data.  Rows are :func:`benchmarks.report.tables.normalise_rows` rows,
``status == 'ok'`` only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

from benchmarks.report.figures import n_words, new_figure, save_figure, system_style  # noqa: E402
from benchmarks.report.measures import SELF_NOISE_TEXT, leaky_count  # noqa: E402
from benchmarks.report.tables import (  # noqa: E402
    SMALL_N_TEXT,
    aggregate,
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

#: Replay and phase-inversion SNR-I further apart than this (dB) are flagged.
HAGERMAN_FLAG_DB = 3.0
#: With ideal (noiseless) sensors an output SNR above this is an idealisation: a 64 dB-SNR
#: MEMS mic (30 dBA) under a 65 dB SPL talker already bounds a linear pair near 38 dB.
IDEAL_SNR_FLAG_DB = 60.0

PHONE_FIELDS = ("snr_i_db", "snr_i_hagerman_db", "snr_i_band_db", "pesq_nb_raw_out",
                "pesq_nb_raw_i", "pesq_wb_out", "stoi_out")  # fmt: skip

_TOLERANCE_KEYS = ("mic_gain_tol_db", "mic_phase_tol_deg", "mic_highpass_tol_hz")


def _pm(rec: dict, f: str, digits: int | None = None) -> str:
    return stat_cell(rec, f, digits)


def _hagerman_cell(rec: dict) -> str:
    """The Hagerman SNR-I over **all** rows, with the leaky rows' count beside it when any."""
    cell = _pm(rec, "snr_i_hagerman_db")
    leaky = rec.get("hagerman_leaky") or 0
    return cell + (f" ({leaky}/{rec['hagerman_rows']} leaky)" if leaky else "")


# -- phones drawn per seed -----------------------------------------------------------------


def phone_rows(ok: Sequence[dict]) -> list[dict]:
    """Rows whose microphones were drawn per seed (a sensor tolerance is set); reverberation
    studies (rows with a ``metric_target``) have their own section (benchmarks.report.reverb)."""
    return [r for r in ok if any(num(T.condition_params(r).get(k)) for k in _TOLERANCE_KEYS) and not r.get("metric_target")]


def phone_summary(rows: Sequence[dict], fields: Sequence[str] = PHONE_FIELDS) -> list[dict[str, Any]]:
    """Per (enhancer, noise): mean over seeds of each seed's mean over input SNRs, with the
    95 % CI over seeds (``<f>_ci95``) and ``n`` seeds; only SNRs every seed has are used.

    >>> rows = [dict(enhancer="eb", noise="babble", noise_field="diffuse", seed=s, snr_in_db=x,
    ...              snr_i_db=float(s + x)) for s in (0, 1) for x in (0.0, 10.0)]
    >>> rec = phone_summary(rows, ("snr_i_db",))[0]
    >>> rec["snr_i_db"], rec["n"]
    (5.5, 2)
    """
    keys = ("enhancer", "noise", "noise_field")
    snr_sets: dict[tuple, dict[Any, set]] = {}
    for r in rows:
        snr_sets.setdefault(tuple(r.get(k) for k in keys), {}).setdefault(r.get("seed"), set()).add(r.get("snr_in_db"))
    # A stratified --limit can leave the seeds no common SNR: then each seed's own SNRs.
    common = {k: set.intersection(*v.values()) or set.union(*v.values()) for k, v in snr_sets.items()}
    sel = [r for r in rows if r.get("snr_in_db") in common[tuple(r.get(k) for k in keys)]]
    out = aggregate_over_seeds(sel, keys, fields)
    for rec in out:
        rec["snr_values_db"] = " ".join(f"{x:g}" for x in sorted(common[tuple(rec[k] for k in keys)]))
        thesis = T.thesis_averages().get((T.thesis_system(rec["enhancer"]) or "", rec["noise"]))
        rec["thesis_snr_i_db"] = thesis["snr_i_db"] if thesis else None
        rec["thesis_pesq_out"] = thesis["pesq_out"] if thesis else None
        mine = [r for r in sel if tuple(r.get(k) for k in keys) == tuple(rec[k] for k in keys)]
        rec["hagerman_leaky"] = leaky_count(mine)
        rec["hagerman_rows"] = sum(num(r.get("snr_i_hagerman_db")) is not None for r in mine)
    order = T.system_order(r["enhancer"] for r in out)
    return sorted(out, key=lambda r: (order.index(r["enhancer"]), str(r["noise"])))


def _phone_figure(summary: Sequence[dict], report_dir: Path) -> Path:
    noises = sorted({r["noise"] for r in summary})
    names = T.system_order(r["enhancer"] for r in summary)
    fig, axes = new_figure(1, 2, figsize=(12, 4.2))
    width = 0.8 / max(len(names), 1)
    for panel, (f, thesis_f, label) in enumerate(
        (("snr_i_db", "thesis_snr_i_db", "SNR-I (dB)"), ("pesq_nb_raw_out", "thesis_pesq_out", "output PESQ (raw P.862)"))
    ):
        ax = axes[panel]
        for i, name in enumerate(names):
            xs, ms, recs, ts = [], [], [], []
            for j, noise in enumerate(noises):
                rec = next((r for r in summary if r["enhancer"] == name and r["noise"] == noise), None)
                if rec is None or rec.get(f) is None:
                    continue
                xs.append(j + (i - (len(names) - 1) / 2) * width)
                ms.append(rec[f])
                recs.append(rec)
                ts.append(rec.get(thesis_f))
            colour, marker = system_style(name)
            ax.bar(xs, ms, width, yerr=error_bars(recs, f), capsize=2, color=colour)
            # the marker on each bar's top tells systems apart where colours are close
            ax.plot(xs, ms, ls="none", marker=marker, color=colour, mec="k", mew=0.5, ms=5, label=name)
            tx = [(x, t) for x, t in zip(xs, ts) if t is not None]
            if tx:
                ax.plot(*zip(*tx), "k_", markersize=14, markeredgewidth=2,
                        label="thesis (ideal mics), printed" if i == names.index(next(
                            n for n in names if T.thesis_system(n))) else None)  # fmt: skip
        fields = {r["noise"]: r.get("noise_field") for r in summary}
        ax.set_xticks(range(len(noises)), [f"{n}\n({fields[n]})" if fields.get(n) else n for n in noises])
        ax.axhline(0.0, color="grey", lw=0.8)
        ax.set(xlabel="noise (field)", ylabel=label)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].legend(fontsize=7, loc="best", ncol=2)
    fig.suptitle(f"{len(names)} systems on realistic phones (sensors drawn per seed), per noise: mean over input SNRs; "
                 f"{n_words([r['n'] for r in summary])}; black bars: the thesis' printed averages (ideal mics)", fontsize=9)  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, report_dir / "phone_vs_thesis.png")


def phone_section(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    rows = phone_rows(ok)
    if not rows:
        return [], []
    summary = phone_summary(rows)
    by_snr = aggregate(rows, ("enhancer", "noise", "noise_field", "snr_in_db"), PHONE_FIELDS)
    paths = [
        write_csv(report_dir / "phone_summary.csv", summary,
                  ["enhancer", "noise", "noise_field", "snr_values_db", "n",
                   *[c for f in PHONE_FIELDS for c in (f, f + "_ci95")], "thesis_snr_i_db", "thesis_pesq_out"]),
        write_csv(report_dir / "phone_by_snr.csv", by_snr,
                  ["enhancer", "noise", "noise_field", "snr_in_db", "n",
                   *[c for f in PHONE_FIELDS for c in (f, f + "_ci95")]]),
    ]  # fmt: skip
    paths.append(_phone_figure(summary, report_dir))
    cond = T.condition_params(rows[0])
    facts = (
        f"±{num(cond.get('mic_gain_tol_db')) or 0:g} dB sensitivity per mic, high-pass corners "
        f"{_fmt_corners(cond.get('mic_highpass_hz'))} ± {num(cond.get('mic_highpass_tol_hz')) or 0:g} Hz, "
        f"self-noise {cond.get('self_noise_dba', 'none')} dBA SPL against a "
        f"{cond.get('speech_spl_db', 65):g} dB SPL talker"
    )
    header = ["system", "noise (field)", "SNR-I (dB)", "SNR-I Hagerman", "SNR-I in band", "PESQ out raw",
              "PESQ-I raw", "PESQ wb out", "STOI out", "n seeds", "thesis SNR-I (ideal mics)", "thesis PESQ out"]  # fmt: skip
    body = [
        [f"`{r['enhancer']}`", f"{r['noise']} ({r['noise_field']})", _pm(r, "snr_i_db"), _hagerman_cell(r),
         _pm(r, "snr_i_band_db"), _pm(r, "pesq_nb_raw_out"), _pm(r, "pesq_nb_raw_i"), _pm(r, "pesq_wb_out"),
         _pm(r, "stoi_out"), str(r["n"]), fmt(r["thesis_snr_i_db"], 1), fmt(r["thesis_pesq_out"])]
        for r in summary
    ]  # fmt: skip
    lines = [
        "## Realistic phones (sensors drawn per seed)",
        "",
        f"Each seed is one phone drawn from the production spread ({facts}), one talker and one "
        "set of noise excerpts; every row records the sensors it was computed with. Per system "
        "and noise: the mean over input SNRs "
        f"({summary[0]['snr_values_db']} dB) of each seed's results, then **the mean over the seeds**; "
        f"{SMALL_N_TEXT} SNR-I by replay of the recorded operation; *Hagerman*: over all rows (leaky rows, whose "
        "speech leak exceeds their noise term, counted beside the mean), "
        "by phase inversion; *in band*: within the band the SNR was set in. PESQ raw = raw P.862. "
        "The thesis columns are its printed averages for ideal mics in its own geometry.",
        "",
        markdown_table(header, body),
        "",
    ]
    return lines, paths


def _fmt_corners(value) -> str:
    if isinstance(value, list) and len(value) == 2:
        return f"{value[0]:g}/{value[1]:g}" if value[0] != value[1] else f"{value[0]:g}"
    return "none" if value is None else str(value)


# -- mismatch sweeps -----------------------------------------------------------------------


def _geometry(row: dict) -> str:
    if row.get("noise_field") in (None, "point") and num(row.get("noise_az_deg")) is not None:
        return f"point {num(row['noise_az_deg']):g}°"
    return str(row.get("noise_field"))


def mismatch_rows(ok: Sequence[dict]) -> list[dict]:
    """Rows of a nominal-mismatch sweep (no per-seed tolerance), with the nominal values."""
    out = []
    for r in ok:
        c = T.condition_params(r)
        if any(num(c.get(k)) for k in _TOLERANCE_KEYS):
            continue
        gain, phase = num(c.get("mic_gain_db")) or 0.0, num(c.get("mic_phase_deg")) or 0.0
        out.append({**r, "nominal_gain_db": gain, "nominal_phase_deg": phase,
                    "self_noise": "none" if c.get("self_noise_dba") is None else f"{c['self_noise_dba']:g} dBA",
                    "geometry": _geometry(r)})  # fmt: skip
    if len(distinct(out, "nominal_gain_db")) < 2 and len(distinct(out, "nominal_phase_deg")) < 2:
        return []
    return out


_MISMATCH_KEYS = ("geometry", "self_noise", "enhancer", "nominal_phase_deg", "nominal_gain_db")
_MISMATCH_FIELDS = ("snr_i_db", "snr_i_hagerman_db", "pesq_nb_raw_out", "pesq_nb_raw_i", "stoi_out")


def _mismatch_figure(agg: Sequence[dict], field: str, ylabel: str, path: Path) -> Path:
    geos = sorted({r["geometry"] for r in agg})
    names = T.system_order(r["enhancer"] for r in agg if r["enhancer"] != "passthrough") or ["passthrough"]
    phases = sorted({r["nominal_phase_deg"] for r in agg})
    noises = sorted({r["self_noise"] for r in agg}, key=lambda v: (v != "none", v))  # noiseless: solid
    fig, axes = new_figure(len(geos), len(names), figsize=(4.2 * len(names), 3.2 * len(geos)), squeeze=False)
    cmap = matplotlib.colormaps["viridis"]
    for i, geo in enumerate(geos):
        for j, name in enumerate(names):
            ax = axes[i, j]
            for k, phase in enumerate(phases):
                for style, sn in zip(("-", "--", ":"), noises):
                    sel = sorted((r for r in agg if (r["geometry"], r["enhancer"], r["nominal_phase_deg"], r["self_noise"])
                                  == (geo, name, phase, sn) and r.get(field) is not None),
                                 key=lambda r: r["nominal_gain_db"])  # fmt: skip
                    if sel:
                        ax.plot([r["nominal_gain_db"] for r in sel], [r[field] for r in sel], style, marker="o",
                                color=cmap(k / max(len(phases) - 1, 1)),
                                label=f"phase {phase:g}°, self-noise {sn}")  # fmt: skip
            ax.set(title=f"{name}, {geo}", xlabel="gain mismatch rear re front (dB)", ylabel=ylabel)
            ax.grid(True, alpha=0.3)
    axes[0, -1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    styles = "; ".join(f"{word}: self-noise {sn}" for word, sn in zip(("solid", "dashed", "dotted"), noises))
    fig.suptitle(f"{ylabel} vs mic mismatch, {len(names)} systems x {len(geos)} noise geometries ({styles})", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def mismatch_section(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    rows = mismatch_rows(ok)
    if not rows:
        return [], []
    agg = aggregate(rows, _MISMATCH_KEYS, _MISMATCH_FIELDS)
    paths = [
        write_csv(report_dir / "mismatch.csv", agg,
                  [*_MISMATCH_KEYS, "n", *[c for f in _MISMATCH_FIELDS for c in (f, f + "_ci95")]]),
        _mismatch_figure(agg, "snr_i_db", "SNR-I (dB)", report_dir / "mismatch_snr_i.png"),
        _mismatch_figure(agg, "pesq_nb_raw_out", "output PESQ (raw P.862)", report_dir / "mismatch_pesq.png"),
    ]  # fmt: skip
    gains = sorted({r["nominal_gain_db"] for r in agg})
    header = ["noise", "self-noise", "system", "phase (°)", *(f"SNR-I @ {g:g} dB" for g in gains)]
    body = []
    keyed = {tuple(r[k] for k in _MISMATCH_KEYS): r for r in agg}
    for geo, sn, name, phase in sorted({tuple(r[k] for k in _MISMATCH_KEYS[:4]) for r in agg},
                                       key=lambda k: (k[0], k[1], T.system_rank(k[2]), k[2], k[3])):  # fmt: skip
        cells = [fmt((keyed.get((geo, sn, name, phase, g)) or {}).get("snr_i_db"), 1) for g in gains]
        body.append([geo, sn, f"`{name}`", f"{phase:g}", *cells])
    lines = [
        "## Microphone mismatch",
        "",
        "SNR-I (dB, replay) per nominal rear-re-front gain mismatch (columns) and phase mismatch, "
        "per noise geometry and self-noise; figures `mismatch_snr_i.png` and `mismatch_pesq.png`, "
        "every column in `mismatch.csv`. One seed per cell unless n says otherwise.",
        "",
        markdown_table(header, body),
        "",
    ]
    return lines, paths


# -- flags ---------------------------------------------------------------------------------


def honesty_flags(ok: Sequence[dict]) -> dict[str, list[dict]]:
    """Rows whose numbers need a caveat (see the module docstring)."""
    hag, above, ideal = [], [], []
    for r in ok:
        a, b = num(r.get("snr_i_db")), num(r.get("snr_i_hagerman_db"))
        if a is not None and b is not None and abs(a - b) > HAGERMAN_FLAG_DB:
            hag.append(r)
        out, limit = num(r.get("snr_out_db")), num(r.get("snr_out_limit_db"))
        if out is not None and limit is not None and out > limit:
            above.append(r)
        if out is not None and limit is None and out > IDEAL_SNR_FLAG_DB:
            ideal.append(r)
    return {"hagerman": hag, "above_self_noise": above, "ideal_high": ideal}


def _by_enhancer(rows: Sequence[dict]) -> str:
    counts: dict[str, int] = {}
    for r in rows:
        counts[str(r.get("enhancer"))] = counts.get(str(r.get("enhancer")), 0) + 1
    return ", ".join(f"{k}: {v}" for k, v in sorted(counts.items(), key=lambda kv: (T.system_rank(kv[0]), kv[0])))


def honesty_section(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    if not ok:
        return [], []
    flags = honesty_flags(ok)
    diffs = {}
    for r in ok:
        a, b = num(r.get("snr_i_db")), num(r.get("snr_i_hagerman_db"))
        if a is not None and b is not None:
            diffs.setdefault(str(r["enhancer"]), []).append(a - b)
    body = [[f"`{k}`", fmt(sum(v) / len(v), 1), fmt(max(v, key=abs), 1), str(sum(abs(x) > HAGERMAN_FLAG_DB for x in v)), str(len(v))]
            for k, v in sorted(diffs.items(), key=lambda kv: (T.system_rank(kv[0]), kv[0]))]  # fmt: skip
    lines = [
        "## What the SNR numbers can and cannot say",
        "",
        f"- **Replay vs phase inversion (Hagerman).** SNR-I by replaying the recorded operation "
        f"on speech and noise, and by phase inversion (process s + n and s − n). Adaptive and "
        f"non-linear systems make them differ; rows more than {HAGERMAN_FLAG_DB:g} dB apart: "
        f"**{len(flags['hagerman'])}** ({_by_enhancer(flags['hagerman']) or 'none'}).",
        "",
        markdown_table(["system", "mean replay − Hagerman (dB)", "largest", f"rows > {HAGERMAN_FLAG_DB:g} dB", "rows"], body),
        "",
        f"- **Self-noise heuristic.** With sensor self-noise, {SELF_NOISE_TEXT}; `snr_out_limit_db` "
        f"applies it broadband, so rows above it are worth a look, not proven wrong (time-varying gains such "
        f"as SS get there by muting noise-only frames): **{len(flags['above_self_noise'])}** "
        f"({_by_enhancer(flags['above_self_noise']) or 'none'}).",
        f"- **Ideal sensors.** Output SNRs above {IDEAL_SNR_FLAG_DB:g} dB with noiseless identical "
        f"mics are an idealisation no microphone delivers (a 64 dB-SNR MEMS mic under a 65 dB SPL "
        f"talker bounds a pair near 38 dB): **{len(flags['ideal_high'])}** rows "
        f"({_by_enhancer(flags['ideal_high']) or 'none'}).",
        "",
    ]
    flagged = [
        {**r, "flag": name}
        for name, rows in flags.items()
        for r in rows
    ]
    paths = []
    if flagged:
        paths.append(write_csv(report_dir / "flags.csv", flagged,
                               ["flag", "condition_id", "enhancer", "noise", "snr_in_db", "seed", "snr_out_db",
                                "snr_i_db", "snr_i_hagerman_db", "snr_out_limit_db"]))  # fmt: skip
    return lines, paths
