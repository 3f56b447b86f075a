"""Report figures (headless matplotlib, PNG): only those the rows support.

* SNR-I and output PESQ vs input SNR per noise, one colour per system, ours solid and the
  thesis dashed (like the thesis' figures 7.2-7.9);
* SNR-I and output PESQ vs RT60 (when the rows hold more than one RT60);
* polar SNR-I vs noise azimuth (when they hold more than one noise azimuth);
* the EB's beta trajectory for one condition (from ``trace_json``).

Each function takes normalised rows (:func:`benchmarks.report_tables.normalise_rows`, only
``status == 'ok'``) and returns the written paths (empty when the data does not support it).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the headless backend)

from benchmarks import thesis_reference as T  # noqa: E402
from benchmarks.report_tables import (  # noqa: E402
    aggregate,
    aggregate_over_seeds,
    distinct,
    modal,
    num,
    sweep_slices,
)

#: Preferred fixed values of the sweeps (the thesis geometry) when several qualify.
RT60_FIXED = ("speech_az_deg", "noise_az_deg")
RT60_PREFER = (T.THESIS_GEOMETRY["speech_az_deg"], T.THESIS_GEOMETRY["noise_az_deg"])
AZIMUTH_FIXED = ("rt60_s", "speech_az_deg")
AZIMUTH_PREFER = (0.0, T.THESIS_GEOMETRY["speech_az_deg"])
#: At most this many azimuth sweeps (e.g. one per RT60) are drawn and tabulated.
MAX_AZIMUTH_GROUPS = 4


def _enhancers(rows) -> list[str]:
    names = distinct(rows, "enhancer")
    return sorted(names, key=lambda n: (T.system_rank(n), str(n)))


def _colours(names: Sequence[str]) -> dict[str, Any]:
    cmap = plt.get_cmap("tab10")
    return {name: cmap(i % 10) for i, name in enumerate(names)}


def _swept_noises(sel: Sequence[dict], vary: str) -> list:
    """Noises for which ``vary`` takes at least two values (a line, not a dot)."""
    return [
        n
        for n in distinct(sel, "noise")
        if len(distinct([r for r in sel if r.get("noise") == n], vary)) >= 2
    ]


def save_figure(fig, path: Path) -> Path:
    """Save ``fig`` as PNG at ``path`` (folder created) and close it: every report figure goes through here."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _errorbar(ax, xs, means, stds, **kw):
    pts = [(x, m, s) for x, m, s in zip(xs, means, stds) if num(x) is not None and m is not None]
    if not pts:
        return
    x, m, s = zip(*pts)
    yerr = [v if v is not None else 0.0 for v in s] if any(v is not None for v in s) else None
    ax.errorbar(x, m, yerr=yerr, capsize=2, **kw)


def snr_sweep_figures(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """One PNG per noise: SNR-I (left) and output PESQ (right) vs input SNR, per system.

    Uses the thesis geometry when the rows have it, else the most common geometry; needs at
    least two input SNRs.  Thesis curves (dashed) are drawn where the system and noise match
    and the geometry is the thesis'.
    """
    geo_keys = ("rt60_s", "speech_az_deg", "noise_az_deg")
    thesis_rows = [r for r in rows if T.is_thesis_condition(r)]
    if thesis_rows:
        subset, at_thesis = thesis_rows, True
        geo = (0.0, T.THESIS_GEOMETRY["speech_az_deg"], T.THESIS_GEOMETRY["noise_az_deg"])
    else:
        geo = modal(rows, geo_keys)
        subset = [r for r in rows if tuple(r.get(k) for k in geo_keys) == geo]
        at_thesis = False
    paths = []
    for noise in distinct(subset, "noise"):
        sel = [r for r in subset if r.get("noise") == noise]
        if len(distinct(sel, "snr_in_db")) < 2:
            continue
        names = _enhancers(sel)
        colours = _colours(names)
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.4))
        for name in names:
            agg = aggregate([r for r in sel if r["enhancer"] == name], ("snr_in_db",))
            xs = [a["snr_in_db"] for a in agg]
            c = colours[name]
            _errorbar(
                ax1,
                xs,
                [a["snr_i_db"] for a in agg],
                [a["snr_i_db_ci95"] for a in agg],
                color=c,
                ls="-",
                marker="o",
                label=name,
            )
            _errorbar(
                ax2,
                xs,
                [a.get("pesq_nb_raw_out") for a in agg],
                [a.get("pesq_nb_raw_out_ci95") for a in agg],
                color=c,
                ls="-",
                marker="o",
                label=f"{name} (raw P.862)",
            )
            _errorbar(
                ax2,
                xs,
                [a["pesq_wb_out"] for a in agg],
                [a["pesq_wb_out_ci95"] for a in agg],
                color=c,
                ls=":",
                marker="s",
                ms=4,
                label=f"{name} (wb)",
            )
            system = T.thesis_system(name)
            if at_thesis and system:
                ref = [t for t in T.load_thesis_tables() if t.system == system and t.noise == noise]
                if ref:
                    ax1.plot(
                        [t.snr_in_db for t in ref],
                        [t.snr_i_db for t in ref],
                        color=c,
                        ls="--",
                        marker="x",
                        label=f"thesis {system}",
                    )
                    ax2.plot(
                        [t.snr_in_db for t in ref],
                        [t.pesq_out for t in ref],
                        color=c,
                        ls="--",
                        marker="x",
                        label=f"thesis {system}",
                    )
        ax1.set(xlabel="input SNR (dB)", ylabel="SNR improvement (dB)", title=f"SNR-I, {noise}")
        ax2.set(
            xlabel="input SNR (dB)", ylabel="output PESQ (raw P.862; wb dotted)", title=f"output PESQ, {noise}"
        )
        ax1.grid(True, alpha=0.3)
        ax2.grid(True, alpha=0.3)
        # One legend outside, from the PESQ panel (it has every line style).
        if ax2.get_legend_handles_labels()[0]:
            ax2.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
        where = "thesis geometry" if at_thesis else _geo_text(geo)
        fig.suptitle(f"{noise}: ours solid, thesis dashed ({where})", fontsize=10)
        fig.tight_layout()
        paths.append(save_figure(fig, out_dir / f"snr_pesq_vs_input_snr_{noise}.png"))
    return paths


def _geo_text(geo) -> str:
    rt60, saz, naz = geo
    return f"RT60 {num(rt60) or 0:g} s, speech {num(saz) or 0:g}°, noise {num(naz) or 0:g}°"


def rt60_figure(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """SNR-I and output PESQ (nb) vs RT60, per noise and system, for the best RT60 sweep
    (:func:`~benchmarks.report_tables.sweep_slices`; thesis angles preferred).  Needs more
    than one RT60."""
    slices = sweep_slices(rows, "rt60_s", RT60_FIXED, prefer=RT60_PREFER)
    if not slices:
        return []
    sel, angles, snrs = slices[0]
    noises = _swept_noises(sel, "rt60_s")
    if not noises:
        return []
    names = _enhancers(sel)
    colours = _colours(names)
    fig, axes = plt.subplots(2, len(noises), figsize=(4.2 * len(noises), 6.5), squeeze=False)
    for j, noise in enumerate(noises):
        for name in names:
            part = [r for r in sel if r["noise"] == noise and r["enhancer"] == name]
            agg = aggregate_over_seeds(part, ("rt60_s",))
            xs = [a["rt60_s"] for a in agg]
            _errorbar(
                axes[0, j],
                xs,
                [a["snr_i_db"] for a in agg],
                [a["snr_i_db_ci95"] for a in agg],
                color=colours[name],
                marker="o",
                label=name,
            )
            _errorbar(
                axes[1, j],
                xs,
                [a["pesq_nb_out"] for a in agg],
                [a["pesq_nb_out_ci95"] for a in agg],
                color=colours[name],
                marker="o",
                label=name,
            )
        axes[0, j].set(title=f"{noise}", ylabel="SNR-I (dB)")
        axes[1, j].set(xlabel="RT60 (s)", ylabel="output PESQ nb")
        for ax in axes[:, j]:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle(
        f"vs RT60 (speech {angles[0]:g}°, noise {angles[1]:g}°; mean ± 95 % CI over seeds at "
        f"input SNR {', '.join(f'{s:g}' for s in snrs)} dB)",
        fontsize=10,
    )
    fig.tight_layout()
    return [save_figure(fig, out_dir / "snr_i_vs_rt60.png")]


def azimuth_figure(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """Polar SNR-I vs noise azimuth per noise and system; one panel per noise and per
    azimuth sweep (e.g. per RT60; :func:`~benchmarks.report_tables.sweep_slices`, at most
    :data:`MAX_AZIMUTH_GROUPS`).  Needs more than one noise azimuth."""
    slices = sweep_slices(
        rows, "noise_az_deg", AZIMUTH_FIXED, prefer=AZIMUTH_PREFER, max_groups=MAX_AZIMUTH_GROUPS
    )
    panels = [
        (sel, base, snrs, noise)
        for sel, base, snrs in slices
        for noise in _swept_noises(sel, "noise_az_deg")
    ]
    if not panels:
        return []
    every = [r for sel, *_ in slices for r in sel]
    names = _enhancers(every)
    colours = _colours(names)
    n_cols = min(3, len(panels))
    n_rows = math.ceil(len(panels) / n_cols)
    fig, axes = plt.subplots(
        n_rows,
        n_cols,
        figsize=(4.6 * n_cols, 4.6 * n_rows + 0.6),
        subplot_kw={"projection": "polar"},
        squeeze=False,
    )
    lo = min(
        (num(r.get("snr_i_db")) for r in every if num(r.get("snr_i_db")) is not None), default=0.0
    )
    for k, (sel, base, snrs, noise) in enumerate(panels):
        ax = axes[k // n_cols, k % n_cols]
        for name in names:
            agg = aggregate_over_seeds(
                [r for r in sel if r["noise"] == noise and r["enhancer"] == name], ("noise_az_deg",)
            )
            pts = sorted(
                (a["noise_az_deg"] % 360.0, a["snr_i_db"]) for a in agg if a["snr_i_db"] is not None
            )
            if not pts:
                continue
            az, r = zip(*pts)
            gaps = [b - a for a, b in zip(az, az[1:])]
            # Close the curve only when the azimuths go all the way round (no large gap).
            if len(pts) > 2 and az[0] + 360.0 - az[-1] <= 1.5 * max(gaps):
                az, r = (*az, az[0] + 360.0), (*r, r[0])
            th = [math.radians(a) for a in az]
            ax.plot(th, r, marker="o", color=colours[name], label=name)
        ax.set_rmin(min(0.0, math.floor(lo)))
        ax.set_title(
            f"{noise}: RT60 {num(base[0]) or 0:g} s, speech {num(base[1]) or 0:g}°, "
            f"SNR {', '.join(f'{s:g}' for s in snrs)} dB",
            fontsize=9,
            pad=14,
        )
    for k in range(len(panels), n_rows * n_cols):
        axes[k // n_cols, k % n_cols].set_visible(False)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=max(1, len(labels)), fontsize=8)
    fig.suptitle("SNR-I (dB) vs noise azimuth (mean over seeds)", fontsize=10)
    fig.tight_layout(rect=(0, 0.5 / (4.6 * n_rows + 0.6), 1, 0.95))
    return [save_figure(fig, out_dir / "snr_i_vs_noise_azimuth.png")]


def _pick_trace_row(rows: Sequence[dict]) -> dict | None:
    with_trace = [r for r in rows if r.get("trace_json")]
    if not with_trace:
        return None

    def rank(r):
        return (
            T.base_name(r.get("enhancer")) != "eb",
            not T.is_thesis_condition(r),
            r.get("noise") != "babble",
            num(r.get("rt60_s")) or 0.0,
            num(r.get("snr_in_db")) if num(r.get("snr_in_db")) is not None else math.inf,
            str(r.get("condition_id")),
        )

    return min(with_trace, key=rank)


def beta_figure(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """The beta trajectory of one condition (an EB at the thesis geometry, babble, lowest
    SNR when available), from ``trace_json``."""
    row = _pick_trace_row(rows)
    if row is None:
        return []
    try:
        trace = json.loads(row["trace_json"])
    except (TypeError, ValueError):
        return []
    fig, ax = plt.subplots(figsize=(8, 3.4))
    drawn = 0
    for key, rec in sorted(trace.items()):
        values = [v if v is not None else math.nan for v in rec.get("values", [])]
        step = num(rec.get("step_s")) or 1.0
        if values:
            ax.plot([i * step for i in range(len(values))], values, lw=1, label=key)
            drawn += 1
    if not drawn:
        plt.close(fig)
        return []
    naz = num(row.get("noise_az_deg"))
    if naz is not None:
        # Low-frequency null-steering beta for this interferer (algorithms.md section 5).
        c = math.cos(math.radians(naz))
        target = 1.0 if c >= 1 - 1e-12 else min(1.0, max(0.0, (1 + c) / (1 - c)))
        ax.axhline(target, color="0.5", ls="--", lw=1,
                   label=f"closed-form null beta for noise at {naz:g}°")  # fmt: skip
    ax.set(xlabel="time (s)", ylabel="beta")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(
        f"{row.get('enhancer')}: {row.get('noise')}, input SNR {num(row.get('snr_in_db')) or 0:g} dB, "
        f"{_geo_text((row.get('rt60_s'), row.get('speech_az_deg'), row.get('noise_az_deg')))}",
        fontsize=9,
    )
    fig.tight_layout()
    return [save_figure(fig, out_dir / "beta_trajectory.png")]


def all_figures(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """Every figure the rows support, written under ``out_dir``."""
    paths: list[Path] = []
    for make in (snr_sweep_figures, rt60_figure, azimuth_figure, beta_figure):
        paths += make(rows, out_dir)
    return paths
