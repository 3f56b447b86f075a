"""Report section for issue 16's measures: distortion, G.160, attribution, per-octave SNR-I, bounds.

* :func:`leaky_count` -- rows whose ``hagerman_leak_db`` is above 0 dB (the phase-inversion
  "noise" is then mostly speech leaking through the change of the system between its two
  runs).  Every Hagerman average is over **all** rows, leaky ones included, with this count
  beside it: dropping them would hide exactly what phase inversion is there to expose.
* :func:`measures_section` -- tables of ``speech_jitter_db`` / ``hagerman_leak_db``, the G.160
  measures beside the recommendation's target ranges, ``snr_i_spectral_db`` /
  ``snr_i_spatial_db``, and one figure per system of the per-octave SNR-I beside the bounds
  that apply to the noise field; the bounds are quoted where they hold (:func:`bounds_lines`).
* :func:`null_phrase`, :data:`SELF_NOISE_TEXT` -- the report's wording of the mismatched null
  and of the self-noise flag, stated where they hold.

Rows are :func:`benchmarks.report.tables.normalise_rows` rows, ``status == 'ok'`` only.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from benchmarks.metrics.attribution import SELF_NOISE_ARRAY_GAIN_DB  # noqa: E402
from benchmarks.metrics.attribution_split import SPLIT_COLUMNS  # noqa: E402
from benchmarks.metrics.g160 import G160_COLUMNS, G160_EXACT_COLUMNS, G160_TARGETS  # noqa: E402
from benchmarks.report.figures import new_figure, save_figure  # noqa: E402
from benchmarks.report.tables import aggregate, fmt, markdown_table, num, write_csv  # noqa: E402
from benchmarks.thesis import reference as T  # noqa: E402

#: Directivity bound of two omni mics in a diffuse field (kd -> 0), 10 log10 4 dB.
DIFFUSE_BOUND_DB = 10.0 * math.log10(4.0)
#: Incoherent noise (wind, self-noise): the white-noise gain of two mics, 10 log10 2 dB.
INCOHERENT_BOUND_DB = SELF_NOISE_ARRAY_GAIN_DB
#: Noise fields bounded by the diffuse / incoherent figure (the rest: no finite linear bound).
FIELD_BOUND_DB = {"diffuse": DIFFUSE_BOUND_DB, "wind": INCOHERENT_BOUND_DB, "incoherent": INCOHERENT_BOUND_DB}
#: Jitter rows at or above this input SNR are held to the issue's -30 dB target.
JITTER_SNR_FROM_DB = 15.0

_FIELDS = ("snr_i_db", "snr_i_spectral_db", "snr_i_spatial_db", *SPLIT_COLUMNS, *G160_COLUMNS, *G160_EXACT_COLUMNS)


def leaky_count(rows: Sequence[dict]) -> int:
    """How many of ``rows`` have ``hagerman_leak_db > 0`` (their Hagerman SNR-I measures the leak).

    >>> leaky_count([{"hagerman_leak_db": 2.0}, {"hagerman_leak_db": -20.0}, {}])
    1
    """
    return sum((num(r.get("hagerman_leak_db")) or -math.inf) > 0.0 for r in rows)


def _db_text(value) -> str:
    v = None if value is None else float(value)
    if v is not None and v == -math.inf:
        return "−∞"
    return fmt(v, 1)


def _max_db(values) -> float | None:
    """Largest value, ``-inf`` counted (a fixed system's jitter); None when there is none."""
    xs = [float(v) for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    return max(xs) if xs else None


def _systems(rows: Sequence[dict]) -> list[str]:
    return T.system_order(r["enhancer"] for r in rows)


def _cells(rows: Sequence[dict]) -> list[tuple[str, str, str, list[dict]]]:
    """``(enhancer, noise, noise_field, rows)`` in the report's system order."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["enhancer"], str(r.get("noise")), str(r.get("noise_field"))), []).append(r)
    order = _systems(rows)
    return [(*k, v) for k, v in sorted(groups.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1]))]


def distortion_lines(rows: Sequence[dict]) -> list[str]:
    """Table: worst ``speech_jitter_db`` (all rows, and input SNR >= 15 dB) and leaky rows."""
    body = []
    for name, noise, _, sel in _cells(rows):
        jit = [r.get("speech_jitter_db") for r in sel]
        if all(j is None for j in jit):
            continue
        high = [r.get("speech_jitter_db") for r in sel if (num(r.get("snr_in_db")) or 0.0) >= JITTER_SNR_FROM_DB]
        leaky = leaky_count(sel)
        body.append([f"`{name}`", noise, _db_text(_max_db(jit)), _db_text(_max_db(high)),
                     _db_text(_max_db(r.get("hagerman_leak_db") for r in sel)), f"{leaky} / {len(sel)}"])  # fmt: skip
    if not body:
        return []
    return [
        "### Speech distortion from adaptation (Hagerman's two runs)",
        "",
        "`speech_jitter_db` = 10 log10 P((W1 − W2) s) / P(W1 s): how much the talker's path moves when "
        "only the noise's sign changes (W1 adapted on s + n, W2 on s − n, both replayed). −∞ for a fixed "
        "system; an adaptation that learns only where the talker is absent gives W1 = W2. Target "
        f"(issue 16): ≤ −30 dB in every row at input SNR ≥ {JITTER_SNR_FROM_DB:g} dB. "
        "`hagerman_leak_db`: power of the speech leak (W1 − W2) s / 2 re the noise term (W1 + W2) n / 2 of "
        "the phase-inversion noise estimate; rows above 0 dB are *leaky* (their Hagerman SNR-I measures the "
        "leak, not the noise): **every Hagerman average is over all rows, with the leaky count beside it**. "
        "Black boxes: not measurable (–).",
        "",
        markdown_table(["system", "noise", "worst jitter (dB)", f"worst jitter, SNR ≥ {JITTER_SNR_FROM_DB:g} dB",
                        "worst leak (dB)", "rows leak > 0 dB"], body),  # fmt: skip
        "",
    ]


def _target_text(key: str) -> str:
    lo, hi = G160_TARGETS[key]
    if lo is not None and hi is not None:
        return f"{lo:g} … {hi:g}"
    return f"≥ {lo:g}" if lo is not None else f"≤ {hi:g}"


def _in_target(key: str, value) -> str:
    v = num(value)
    if v is None:
        return ""
    lo, hi = G160_TARGETS[key]
    return "" if (lo is None or v >= lo) and (hi is None or v <= hi) else " ✗"


def g160_lines(agg: Sequence[dict]) -> list[str]:
    """Table of the G.160 measures (mean over the cell's rows) beside the target ranges, with the
    exact replayed values beside them where the system is replayable."""
    exact = any(r.get(k) is not None for r in agg for k in G160_EXACT_COLUMNS)
    body = [[f"`{r['enhancer']}`", str(r["noise"]), *(fmt(r.get(k), 1) + _in_target(k, r.get(k)) for k in G160_COLUMNS),
             *((fmt(r.get(k), 1) for k in G160_EXACT_COLUMNS) if exact else ()), str(r["n"])]
            for r in agg if any(r.get(k) is not None for k in G160_COLUMNS)]  # fmt: skip
    if not body:
        return []
    short = [k.removeprefix("g160_").removesuffix("_db").upper() for k in G160_COLUMNS]
    head = ["system", "noise", *(f"{s} (dB; target {_target_text(k)})" for s, k in zip(short, G160_COLUMNS)),
            *((f"{s} exact" for s in short) if exact else ()), "rows"]  # fmt: skip
    return [
        "### ITU-T G.160 Appendix II measures",
        "",
        "SNRI, TNLR and DSN (`benchmarks.metrics.g160`, definition v2: 10 ms frames, speech activity from "
        "the clean speech by ITU-T P.56 method B with its 0.2 s hangover, levels as means of dB over speech "
        "/ noise-only frames) on **one footing for every system**: the recommendation's own estimate from "
        "mixture and output (noise-power subtraction). *exact*: the same measures from the replayed speech "
        "and noise parts, where the system is replayable -- their difference is the estimate's error. "
        "Means over every input SNR of the cell; ✗ marks a mean outside the recommendation's target "
        "range. The targets are stated for the recommendation's own conditions (car and street noise at "
        "6–18 dB), so they are guidelines here, not a pass mark; the module's docstring lists what of "
        "the recommendation's text could not be verified.",
        "",
        markdown_table(head, body),
        "",
    ]


def attribution_lines(agg: Sequence[dict]) -> list[str]:
    """Table: SNR-I split into a fixed single-mic EQ's share and the rest (spatial / time-varying)."""
    body = [[f"`{r['enhancer']}`", str(r["noise"]), fmt(r.get("snr_i_db"), 1), fmt(r.get("snr_i_spectral_db"), 1),
             fmt(r.get("snr_i_spatial_db"), 1), str(r["n"])] for r in agg if r.get("snr_i_spectral_db") is not None]  # fmt: skip
    if not body:
        return []
    return [
        "### Where the SNR-I comes from",
        "",
        "`snr_i_spectral_db`: the SNR-I of the reference mic through one fixed linear-phase FIR whose "
        "magnitude is the system's long-term speech response — what any single-mic fixed EQ with the same "
        "effect on the talker gives (high-pass, roll-off). `snr_i_spatial_db` = `snr_i_db` − that: what "
        "the second mic and time-varying gains add. Means over the cell's rows.",
        "",
        markdown_table(["system", "noise", "SNR-I (dB)", "spectral (fixed EQ)", "spatial + time-varying", "rows"], body),
        "",
        *split_lines(agg),
    ]


def split_lines(agg: Sequence[dict]) -> list[str]:
    """Table: the three-way split at the 1/3-octave rule (replayable systems only)."""
    body = [[f"`{r['enhancer']}`", str(r["noise"]), fmt(r.get("snr_i_db"), 1), *(fmt(r.get(k), 1) for k in SPLIT_COLUMNS),
             str(r["n"])] for r in agg if r.get("snr_i_time_varying_db") is not None]  # fmt: skip
    if not body:
        return []
    return [
        "Split three ways at a 1/3-octave resolution: a fixed EQ, what a fixed two-mic filter adds, and "
        "the time-varying rest (the three sum to the SNR-I; `benchmarks.metrics.attribution_split`). "
        "Replayable systems only. Means over the cell's rows.",
        "",
        markdown_table(["system", "noise", "SNR-I (dB)", "fixed EQ", "fixed 2-mic", "time-varying", "rows"], body),
        "",
    ]


def is_fixed_system(rows: Sequence[dict]) -> bool:
    """True when every row's ``speech_jitter_db`` is −∞: a replayed system whose two Hagerman
    runs applied the same operation, i.e. linear and time-invariant on these rows (the only
    systems the linear bounds hold for)."""
    jit = [num(r.get("speech_jitter_db")) for r in rows]
    return bool(jit) and all(j is not None and j == -math.inf for j in jit)


def octave_summary(rows: Sequence[dict]) -> list[dict[str, Any]]:
    """Per (enhancer, noise, noise_field, RT60): mean per-octave SNR-I and self-noise limit over rows,
    ``n`` rows and ``fixed`` (:func:`is_fixed_system`)."""
    out = []
    for name, noise, field, sel in _cells(rows):
        for rt in sorted({num(r.get("rt60_s")) or 0.0 for r in sel}):
            mine = [r for r in sel if (num(r.get("rt60_s")) or 0.0) == rt]
            parsed = [json.loads(r["snr_i_octave_json"]) for r in mine if r.get("snr_i_octave_json")]
            if not parsed:
                continue
            centres = parsed[0]["centre_hz"]
            gains = np.array([p["snr_i_db"] for p in parsed if p["centre_hz"] == centres], dtype=float)
            limits = [p["self_noise_limit_db"] for p in parsed if p["centre_hz"] == centres and p.get("self_noise_limit_db")]
            out.append({"enhancer": name, "noise": noise, "noise_field": field, "rt60_s": rt, "centre_hz": centres,
                        "snr_i_db": gains.mean(axis=0).tolist(), "n": len(gains), "fixed": is_fixed_system(mine),
                        "self_noise_limit_db": np.mean(limits, axis=0).tolist() if limits else None})  # fmt: skip
    return out


def _drawn(rec: dict) -> bool:
    """A system whose every band's SNR-I is 0 (the input itself) would be an empty figure: not drawn."""
    return any(abs(g) > 1e-9 for g in rec["snr_i_db"])


def _octave_panel(ax, recs: Sequence[dict]) -> None:
    """Per-octave SNR-I of each system of ``recs`` (one noise, one RT60) on ``ax``; the noise
    field's linear bound only when a fixed (LTI) system is drawn, naming those it holds for."""
    from benchmarks.report.figures import system_style

    x = np.arange(len(recs[0]["centre_hz"]))
    for rec in recs:
        colour, marker = system_style(rec["enhancer"])
        ax.plot(x, rec["snr_i_db"], color=colour, marker=marker, ls="-" if rec["fixed"] else "--", ms=4,
                label=f"{rec['enhancer']}, n={rec['n']}")  # fmt: skip
    fixed = [r["enhancer"] for r in recs if r["fixed"]]
    bound = FIELD_BOUND_DB.get(recs[0]["noise_field"])
    if bound is not None and fixed:
        ax.axhline(bound, color="k", ls=":", lw=1, label=f"LTI bound {bound:.2f} dB ({', '.join(fixed)})")
    limit = next((r["self_noise_limit_db"] for r in recs if r["self_noise_limit_db"]), None)
    if limit:
        ax.plot(x, limit, "r_", ms=14, mew=2, label="self-noise limit (per band)")
    ax.set_xticks(x, [f"{c:g}" for c in recs[0]["centre_hz"]], fontsize=7)
    ax.axhline(0.0, color="grey", lw=0.8)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("octave centre (Hz)")


def octave_figures(summary: Sequence[dict], report_dir: Path) -> list[Path]:
    """One PNG per noise: per-octave SNR-I of every system (a line each, in its report-wide
    colour and marker; solid fixed systems, dashed time-varying ones), one panel per RT60.

    Systems with no SNR-I in any band (``passthrough``) are left out; the linear bound of the
    noise field is drawn only where a fixed system is, and says which."""
    paths = []
    kept = [r for r in summary if _drawn(r)]
    for noise in sorted({r["noise"] for r in kept}):
        mine = [r for r in kept if r["noise"] == noise]
        rts = sorted({r["rt60_s"] for r in mine})
        fig, axes = new_figure(1, len(rts), figsize=(5.2 * len(rts) + 2.4, 3.8), squeeze=False, sharey=True)
        for ax, rt in zip(axes[0], rts):
            recs = [r for r in mine if r["rt60_s"] == rt]
            recs.sort(key=lambda r: T.system_order(x["enhancer"] for x in mine).index(r["enhancer"]))
            _octave_panel(ax, recs)
            ax.set_title(f"{noise} ({recs[0]['noise_field']})" + (f", RT60 {rt:g} s" if len(rts) > 1 else ""), fontsize=9)
        for ax in axes[0]:
            ax.set_ylabel("SNR-I (dB)")
        axes[0][-1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
        n = sorted({r["n"] for r in mine})
        fig.suptitle(f"{noise}: per-octave SNR-I, mean over n = {n[0]}{'' if len(n) == 1 else f'–{n[-1]}'} rows per "
                     "line; solid: fixed (LTI) systems, dashed: time-varying", fontsize=9)  # fmt: skip
        fig.tight_layout()
        paths.append(save_figure(fig, report_dir / f"octave_snr_i_{noise}.png"))
    return paths


def null_by_band(gain_db: float = 0.5, phase_deg: float = 2.0) -> dict[str, float]:
    """Null depth (dB re look) of the thesis' broadside plane wave under a mic mismatch, per octave.

    ``cF - cB`` (beta = 1) at 270°, 2.14 cm pair (:func:`enhancers.beam.differential.mismatch_null_depth_db`).
    A per-frequency ratio is the same before and after the look EQ; the EQ only changes how the
    broadband figure weights the bands: ``"white"`` is the unequalised output for white noise,
    ``"eq_speech"`` the equalised output for speech-shaped noise (LTASS, 100 Hz - 7 kHz).

    >>> d = null_by_band()
    >>> round(d["1000"]), round(d["white"]), round(d["125"])
    (-15, -23, 1)
    """
    from data_recipes.ltass import ltass_psd_db
    from enhancers.beam.differential import mismatch_null_depth_db, plane_wave_response

    kw = dict(beta=1.0, rear_gain_db=gain_db, rear_phase_deg=phase_deg)
    out = {}
    for c in (125, 250, 500, 1000, 2000, 4000):
        out[str(c)] = mismatch_null_depth_db(np.linspace(c / math.sqrt(2), c * math.sqrt(2), 200), 270.0, **kw)
    f = np.linspace(100.0, 7000.0, 3000)
    out["white"] = mismatch_null_depth_db(f, 270.0, **kw)
    look = np.abs(plane_wave_response(f, 0.0, **kw)) ** 2
    out["eq_speech"] = mismatch_null_depth_db(f, 270.0, weights=10 ** (ltass_psd_db(f) / 10) / look, **kw)
    return out


def null_phrase(gain_db: float = 0.5, phase_deg: float = 2.0) -> str:
    """The mismatched null as the report states it: per band after the look EQ, and broadband."""
    d = null_by_band(gain_db, phase_deg)
    return (f"a {gain_db:g} dB / {phase_deg:g}° mismatch between the mics leaves that null {-d['white']:.0f} dB "
            f"below the look direction only for the unequalised output and white noise; after the look EQ "
            f"every EB applies it is {d['125']:+.0f} dB at 125 Hz, {d['250']:+.0f} dB at 250 Hz, "
            f"{d['1000']:+.0f} dB at 1 kHz and {d['eq_speech']:+.1f} dB broadband for speech-shaped noise")  # fmt: skip


#: The self-noise flag, stated where it holds (per frequency bin) and called a heuristic broadband.
SELF_NOISE_TEXT = (
    "no linear two-mic system raises the speech-to-self-noise ratio by more than 3 dB *in any one "
    "frequency bin* (white-noise gain ≤ 2); broadband this is a heuristic, not a bound — a fixed "
    "low-pass on one mic already beats it when the speech spectrum falls and the self-noise is white "
    "(the per-band limits are in the per-octave figures)"
)


def bounds_lines() -> list[str]:
    """The bounds quoted where they hold: the mismatched null per band, the self-noise limit per bin."""
    d = null_by_band()
    body = [[f"{c}", f"{d[c]:+.1f}"] for c in ("125", "250", "500", "1000", "2000", "4000")]
    body += [["broadband, white, unequalised", f"{d['white']:+.1f}"], ["broadband, speech-shaped, after the look EQ", f"{d['eq_speech']:+.1f}"]]
    return [
        "### Bounds, where they hold",
        "",
        f"- **Diffuse noise**: two omni mics reach at most {DIFFUSE_BOUND_DB:.2f} dB directivity (kd → 0); "
        f"**incoherent noise** (wind, self-noise): {INCOHERENT_BOUND_DB:.2f} dB. Both per frequency, for "
        "linear time-invariant processing; time-varying gains (SS) are not bound by them.",
        f"- **Self-noise**: {SELF_NOISE_TEXT}.",
        "- **Mismatched null** of one broadside plane wave (the thesis' noise), 0.5 dB / 2° rear-mic "
        "mismatch, dipole (β = 1), null depth re the look direction per octave — the same before and after "
        "the look EQ, which only re-weights the bands in a broadband figure:",
        "",
        markdown_table(["octave (Hz)", "null re look (dB)"], body),
        "",
    ]


def measures_section(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    """Markdown lines and written paths (CSV, PNG) of the issue-16 measures; empty without them."""
    rows = [r for r in ok if any(r.get(k) is not None for k in ("snr_i_spectral_db", "g160_snri_db", "speech_jitter_db"))]
    if not rows:
        return [], []
    agg = aggregate(rows, ("enhancer", "noise"), _FIELDS)
    order = _systems(rows)
    agg.sort(key=lambda r: (order.index(r["enhancer"]), str(r["noise"])))
    summary = octave_summary(rows)
    paths = [write_csv(report_dir / "measures.csv", agg, ["enhancer", "noise", "n", *_FIELDS]),
             *octave_figures(summary, report_dir)]  # fmt: skip
    lines = ["## Distortion, G.160 and attribution", "", *distortion_lines(rows), *g160_lines(agg),
             *attribution_lines(agg), *bounds_lines(),
             "Per-octave SNR-I per noise: figures `octave_snr_i_<noise>.png` (a line per system in its "
             "colour; a panel per RT60 when RT60 is swept; dotted: the noise field's bound for linear "
             "time-invariant systems, drawn only beside those; red: the per-band self-noise limit; "
             "systems without SNR-I in any band, the input itself, are not drawn).", ""]  # fmt: skip
    return lines, paths
