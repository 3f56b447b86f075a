"""Report figures (headless matplotlib, PNG): only those the rows support.

* SNR-I and output PESQ vs input SNR per noise, one colour per system, ours solid and the
  thesis dashed (like the thesis' figures 7.2-7.9);
* SNR-I and output PESQ vs RT60 (when the rows hold more than one RT60);
* polar SNR-I vs noise azimuth (when they hold more than one noise azimuth);
* the EB's beta trajectory for one condition (from ``trace_json``).

Each function takes normalised rows (:func:`benchmarks.report.tables.normalise_rows`, only
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
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402

from benchmarks.report.tables import (  # noqa: E402
    MIN_T_SEEDS,
    aggregate_over_seeds,
    distinct,
    drawn_keys,
    group_drawn,
    interval_clipped,
    modal,
    num,
    seed_interval,
    seed_means,
    sweep_slices,
)
from benchmarks.thesis import reference as T  # noqa: E402

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


#: 16 colour-blind-safe colours: Okabe & Ito (2008) without its yellow (unreadable on white),
#: then Paul Tol's muted scheme (2021, "Colour schemes", SRON/EPS/TN/09-002) and two of his
#: bright scheme's; no colour is repeated.
PALETTE = ("#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#000000",
           "#882255", "#332288", "#117733", "#44AA99", "#88CCEE", "#999933", "#AA4499", "#DDCC77", "#BBBBBB")
#: 12 markers: style ``i`` is (colour ``i mod 16``, marker ``i mod 12``), all distinct for i < 48.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "h", "p")
#: Systems with a fixed style, in this order (the thesis' systems first): a system keeps its
#: colour and marker in every report.  Every registered name is here (tested); names not
#: here (versioned ``name@1``, plugins) take one of the remaining styles by a stable hash.
KNOWN_SYSTEMS = (
    "passthrough", "eb", "ss", "eb-ss", "eb-robust", "eb-robust-ss", "mmse-lsa", "superdirective", "mvdr", "mwf",
    "mvdr-ss", "webrtc-ns", "rnnoise", "dfn3", "eb-robust-dfn3", "wpe", "wpe-eb-robust", "wpe-eb-robust-ss",
    "cardioid", "hypercardioid", "das", "eb-subband", "mic-calibration", "ss-ms2001", "eb-gated", "eb-spp",
    "eb-spp-ss", "eb-robust-blind", "eb-robust-blind-ss",
)  # fmt: skip
N_STYLES = 48


def system_style(name: str) -> tuple[str, str]:
    """``(colour, marker)`` of a system, the same in every report and figure.

    A name of :data:`KNOWN_SYSTEMS` takes the style of its position; any other name one of
    the remaining ``N_STYLES - len(KNOWN_SYSTEMS)`` styles by SHA-256 of the name (stable
    across runs and machines; two unknown names may share one).

    >>> system_style("passthrough"), system_style("eb")
    (('#0072B2', 'o'), ('#E69F00', 's'))
    >>> system_style("my-plugin") == system_style("my-plugin")
    True
    """
    import hashlib

    if name in KNOWN_SYSTEMS:
        i = KNOWN_SYSTEMS.index(name)
    else:
        spare = N_STYLES - len(KNOWN_SYSTEMS)
        i = len(KNOWN_SYSTEMS) + int(hashlib.sha256(str(name).encode("utf-8")).hexdigest(), 16) % spare
    return PALETTE[i % len(PALETTE)], MARKERS[i % len(MARKERS)]


#: Resolution of every saved figure (a test lowers it to render quickly).
DPI = 110
#: zlib level of the PNGs: the same pixels; 3 instead of Pillow's 6 encodes a report's 15
#: figures in ~70 % of the CPU for ~4 % more bytes (measured on the ``phone`` report).
PNG_COMPRESS_LEVEL = 3


def _colours(names: Sequence[str]) -> dict[str, Any]:
    return {name: system_style(name)[0] for name in names}


def _markers(names: Sequence[str]) -> dict[str, str]:
    return {name: system_style(name)[1] for name in names}


def interval_words(n: int) -> str:
    """How an interval over ``n`` seeds is drawn (see :func:`report_tables.seed_interval`).

    >>> interval_words(2), interval_words(5)
    ('min–max over 2 seeds', '95 % t-interval over 5 seeds')
    """
    if n < 2:
        return "1 seed, no interval"
    return f"min–max over {n} seeds" if n < MIN_T_SEEDS else f"95 % t-interval over {n} seeds"


def seed_counts(rows: Sequence[dict], keys: Sequence[str]) -> list[int]:
    """The number of seeds behind each drawn point: distinct seeds per group of ``keys``.

    >>> seed_counts([{"e": "a", "seed": 0}, {"e": "a", "seed": 1}, {"e": "b", "seed": 0}], ("e",))
    [2, 1]
    """
    groups: dict[tuple, set] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in keys), set()).add(r.get("seed"))
    return [len(v) for v in groups.values()]


def n_words(counts: Sequence[int]) -> str:
    """How the points' intervals are drawn, from the seeds each point actually holds.

    >>> n_words([5, 5]), n_words([1, 3])
    ('95 % t-interval over 5 seeds', 'n = 1–3 seeds per point (1: no interval; 2–4: min–max; ≥ 5: 95 % t-interval)')
    """
    if not counts:
        return "no points"
    lo, hi = min(counts), max(counts)
    if lo == hi:
        return interval_words(lo)
    return (f"n = {lo}–{hi} seeds per point (1: no interval; 2–{MIN_T_SEEDS - 1}: min–max; "
            f"≥ {MIN_T_SEEDS}: 95 % t-interval)")


def _swept_noises(sel: Sequence[dict], vary: str) -> list:
    """Noises for which ``vary`` takes at least two values (a line, not a dot)."""
    return [
        n
        for n in distinct(sel, "noise")
        if len(distinct([r for r in sel if r.get("noise") == n], vary)) >= 2
    ]


#: The one headless figure every report figure is drawn on (cleared in between), see :func:`new_figure`.
_FIGURE: list = []


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], reuse=None, **subplots_kw):
    """``(figure, axes)`` like ``pyplot.subplots``, on one reused headless figure at :data:`DPI`.

    Why reused and not pyplot's: a report draws ~15 figures, mostly of a few sizes, and
    matplotlib caches text extents per renderer, which the Agg canvas keeps while the size
    and resolution stay the same (a new figure, or laying it out at another dpi than it is
    saved at, measures every label again).  Call :func:`save_figure` before the next
    :func:`new_figure`: it clears the figure.

    ``reuse``: the axes the previous call returned (``squeeze=False``).  When they are still
    on the figure and have this shape and size, they are emptied and returned instead of new
    ones (new axes and their ticks cost as much as drawing them; a series of figures of one
    layout, one per system or noise, only changes what is drawn on them).

    >>> fig, ax = new_figure(figsize=(2.0, 1.5))
    >>> fig2, axes = new_figure(1, 2, figsize=(3.0, 1.5), squeeze=False)
    >>> fig2 is fig, axes.shape, ax in fig2.axes
    (True, (1, 2), False)
    >>> _ = axes[0, 0].plot([1, 2], [3, 4])
    >>> _, again = new_figure(1, 2, figsize=(3.0, 1.5), squeeze=False, reuse=axes)
    >>> again is axes, len(again[0, 0].lines)
    (True, 0)
    """
    if not _FIGURE:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        _FIGURE.append(Figure())
        FigureCanvasAgg(_FIGURE[0])
    fig = _FIGURE[0]
    same = reuse is not None and reuse.shape == (nrows, ncols) and fig.get_dpi() == DPI
    if same and list(reuse.flat) == fig.axes and tuple(fig.get_size_inches()) == tuple(figsize):
        _empty(fig, reuse)
        return fig, reuse
    for ax in list(fig.axes):  # removed first: ``clear`` would reset each axes (as costly as a new one)
        fig.delaxes(ax)
    fig.clear()
    fig.set_dpi(DPI)
    fig.set_size_inches(figsize)
    return fig, fig.subplots(nrows, ncols, **subplots_kw)


def _empty(fig, axes) -> None:
    """Remove what was drawn on ``axes`` (keeping them and their ticks) and undo the layout."""
    fig.subplotpars.reset()
    fig.subplots_adjust()
    for artist in [*fig.texts, *fig.legends]:  # the suptitle is one of the texts
        artist.remove()
    for ax in axes.flat:
        for container in list(ax.containers):  # a bar or error-bar container removes its parts too
            container.remove()
        for artist in [*ax.lines, *ax.patches, *ax.texts, *ax.collections]:
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.set_title("")
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.__dict__.pop("_clip_noted", None)
        ax.relim()
        ax.autoscale_view()


def save_figure(fig, path: Path) -> Path:
    """Save ``fig`` as PNG at ``path`` (folder created) and clear it: every report figure goes through here."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        # ``tight_layout`` leaves a placeholder engine behind, and any engine makes ``savefig``
        # draw the whole figure once more before the real draw.  The layout is already
        # applied: drop the engine.
        with matplotlib.rc_context({"figure.autolayout": False, "figure.constrained_layout.use": False}):
            fig.set_layout_engine(None)
    fig.savefig(path, dpi=DPI, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path


def _seed_points(rows: Sequence[dict], x_key: str, field: str) -> list[tuple[float, float, float, float, bool]]:
    """``(x, mean, lo, hi, clipped)`` per value of ``x_key``: per-seed means, then
    :func:`~benchmarks.report.tables.seed_interval` (clipped to the metric's range; ``clipped``
    says so)."""
    out = []
    for x in distinct(rows, x_key):
        vals = seed_means([r for r in rows if r.get(x_key) == x], field)
        m, lo, hi = seed_interval(vals, field)
        if m is not None and num(x) is not None:
            out.append((float(x), m, lo, hi, interval_clipped(vals, field)))
    return out


def _errorbar(ax, pts, **kw):
    """Draw ``(x, mean, lo, hi, clipped)`` points with asymmetric error bars (nothing without
    points); a clipped bar gets a black × at both ends and the panel a note saying so."""
    if not pts:
        return
    x, m, lo, hi, clipped = zip(*pts)
    ax.errorbar(x, m, yerr=[[a - b for a, b in zip(m, lo)], [b - a for a, b in zip(m, hi)]], capsize=2, **kw)
    _mark_clipped(ax, [(xi, a, b) for xi, a, b, c in zip(x, lo, hi, clipped) if c])


def _mark_clipped(ax, ends, *, vertical: bool = True) -> None:
    """Mark clipped intervals ``(x, lo, hi)`` (or ``(y, lo, hi)`` horizontally) and say so once per panel."""
    if not ends:
        return
    for pos, lo, hi in ends:
        xs, ys = ([pos, pos], [lo, hi]) if vertical else ([lo, hi], [pos, pos])
        ax.plot(xs, ys, "kx", ms=6, zorder=5)
    if not getattr(ax, "_clip_noted", False):
        ax.text(0.01, 0.01, "× interval clipped to the metric's range", transform=ax.transAxes, fontsize=6, va="bottom")
        ax._clip_noted = True


def snr_sweep_figures(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """One PNG per noise present: SNR-I (left) and output raw PESQ (right) vs input SNR, per system.

    Uses the thesis geometry when the rows have it, else the most common geometry.  Thesis
    curves (dashed) are drawn where the system and noise match and the geometry is the
    thesis'; the title says so only when one is drawn.  Rows whose noise azimuth is drawn per
    seed are grouped by their noise field instead of their azimuth.
    """
    geo_keys = ("rt60_s", "speech_az_deg", "noise_az_deg")
    rows = [r for r in group_drawn(rows) if num(r.get("snr_in_db")) is not None]  # no empty figure
    thesis_rows = [r for r in rows if T.is_thesis_condition(r)]
    if thesis_rows:
        subset, at_thesis = thesis_rows, True
        geo = (0.0, T.THESIS_GEOMETRY["speech_az_deg"], T.THESIS_GEOMETRY["noise_az_deg"])
    else:
        geo = modal(rows, geo_keys)
        subset = [r for r in rows if tuple(r.get(k) for k in geo_keys) == geo]
        at_thesis = False
    paths, axes = [], None
    for noise in distinct(subset, "noise"):
        sel = [r for r in subset if r.get("noise") == noise]
        names = _enhancers(sel)
        colours, markers = _colours(names), _markers(names)
        fig, axes = new_figure(1, 2, figsize=(11, 4.2), squeeze=False, reuse=axes)
        ax1, ax2 = axes[0]
        drew_thesis = False
        for name in names:
            mine = [r for r in sel if r["enhancer"] == name]
            kw = dict(color=colours[name], marker=markers[name], ls="-", label=name)
            _errorbar(ax1, _seed_points(mine, "snr_in_db", "snr_i_db"), **kw)
            _errorbar(ax2, _seed_points(mine, "snr_in_db", "pesq_nb_raw_out"), **kw)
            system = T.thesis_system(name)
            ref = [t for t in T.load_thesis_tables() if t.system == system and t.noise == noise] if at_thesis and system else []
            if ref:
                drew_thesis = True
                for ax, f in ((ax1, "snr_i_db"), (ax2, "pesq_out")):
                    ax.plot([t.snr_in_db for t in ref], [getattr(t, f) for t in ref], color=colours[name], ls="--",
                            marker="x", label=f"thesis {system}")  # fmt: skip
        ax1.set(xlabel="input SNR (dB)", ylabel="SNR improvement (dB)")
        ax2.set(xlabel="input SNR (dB)", ylabel="output PESQ (raw P.862, MOS)")
        for ax in (ax1, ax2):
            ax.grid(True, alpha=0.3)
        ax1.legend(fontsize=7, loc="best", ncol=2 if len(names) > 5 else 1)
        where = "thesis geometry" if at_thesis else _geo_text(geo)
        thesis = "; thesis' printed values dashed" if drew_thesis else ""
        fig.suptitle(f"{noise}: {len(names)} systems vs input SNR ({where}); "
                     f"{n_words(seed_counts(sel, ('enhancer', 'snr_in_db')))}{thesis}",
                     fontsize=9)  # fmt: skip
        fig.tight_layout()
        paths.append(save_figure(fig, out_dir / f"snr_pesq_vs_input_snr_{noise}.png"))
    return paths


def _geo_text(geo) -> str:
    rt60, saz, naz = geo
    noise = f"noise {num(naz):g}°" if num(naz) is not None else "noise azimuth drawn per seed"
    return f"RT60 {num(rt60) or 0:g} s, speech {num(saz) or 0:g}°, {noise}"


def rt60_figure(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """SNR-I and output PESQ (raw) vs RT60, per noise and system, for the best RT60 sweep
    (:func:`~benchmarks.report.tables.sweep_slices`; thesis angles preferred).  Needs more
    than one RT60."""
    slices = sweep_slices(rows, "rt60_s", RT60_FIXED, prefer=RT60_PREFER)
    if not slices:
        return []
    sel, angles, snrs = slices[0]
    noises = _swept_noises(sel, "rt60_s")
    if not noises:
        return []
    names = _enhancers(sel)
    colours, markers = _colours(names), _markers(names)
    fig, axes = new_figure(2, len(noises), figsize=(4.2 * len(noises), 6.5), squeeze=False)
    for j, noise in enumerate(noises):
        for name in names:
            part = [r for r in sel if r["noise"] == noise and r["enhancer"] == name]
            kw = dict(color=colours[name], marker=markers[name], label=name)
            _errorbar(axes[0, j], _seed_points(part, "rt60_s", "snr_i_db"), **kw)
            _errorbar(axes[1, j], _seed_points(part, "rt60_s", "pesq_nb_raw_out"), **kw)
        axes[0, j].set(title=f"{noise}", ylabel="SNR-I (dB)")
        axes[1, j].set(xlabel="RT60 (s)", ylabel="output PESQ (raw P.862, MOS)")
        for ax in axes[:, j]:
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(
        f"{len(names)} systems vs RT60 (speech {angles[0]:g}°, noise {angles[1]:g}°; mean over input SNR "
        f"{', '.join(f'{s:g}' for s in snrs)} dB per seed; {n_words(seed_counts(sel, ('noise', 'enhancer', 'rt60_s')))})",
        fontsize=9,
    )
    fig.tight_layout()
    return [save_figure(fig, out_dir / "snr_i_vs_rt60.png")]


def azimuth_figure(rows: Sequence[dict], out_dir: Path) -> list[Path]:
    """Polar SNR-I vs noise azimuth per noise and system; one panel per noise and per
    azimuth sweep (e.g. per RT60; :func:`~benchmarks.report.tables.sweep_slices`, at most
    :data:`MAX_AZIMUTH_GROUPS`).  Only swept azimuths: rows whose azimuth was drawn per seed
    are left out.  Needs more than one noise azimuth."""
    rows = [r for r in rows if "noise_az_deg" not in drawn_keys(r)]
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
    colours, markers = _colours(names), _markers(names)
    n_cols = min(3, len(panels))
    n_rows = math.ceil(len(panels) / n_cols)
    legend_h = 0.35 * math.ceil(len(names) / 4)
    fig, axes = new_figure(
        n_rows,
        n_cols,
        figsize=(4.6 * n_cols, 4.6 * n_rows + 0.6 + legend_h),
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
            ax.plot(th, r, marker=markers[name], color=colours[name], label=name)
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
    fig.legend(handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=8)
    height = 4.6 * n_rows + 0.6 + legend_h
    counts = seed_counts(every, ("noise", "enhancer", "noise_az_deg", *AZIMUTH_FIXED))
    fig.suptitle(f"SNR-I (dB, radius) vs noise azimuth (°), {len(names)} systems; mean over "
                 f"{min(counts)}–{max(counts)} seed(s) per point", fontsize=10)  # fmt: skip
    fig.tight_layout(rect=(0, (legend_h + 0.2) / height, 1, 0.95))
    return [save_figure(fig, out_dir / "snr_i_vs_noise_azimuth.png")]


def _overview_panels(ok: Sequence[dict]):
    """``(x field, x label, [(y field, y label)], x is per-condition key)`` for the overview."""
    if any(r.get("metric_target") for r in ok) and len(distinct(ok, "rt60_s")) > 1:
        return "rt60_s", "RT60 (s)", [("sinr_i_db", "SINR-I (dB)"), ("c50_gain_db", "C50 gain (dB)")], True
    return "snr_i_db", "SNR-I (dB)", [("pesq_nb_raw_out", "output PESQ (raw P.862, MOS)"), ("stoi_out", "output STOI")], False


def overview_figure(ok: Sequence[dict], out_dir: Path) -> list[Path]:
    """The figure a report opens with: per noise (columns), each system's quality against its
    SNR-I (or, for reverberation studies, SINR-I and C50 gain against RT60), every point a mean
    over seeds of each seed's mean over the noise's conditions, with the seeds' interval."""
    if not ok:
        return []
    x_f, x_label, panels, x_is_key = _overview_panels(ok)
    if x_is_key:
        ok = [dict(r, c50_gain_db=(num(r.get("c50_out_db")) - num(r.get("c50_in_db")))
                   if num(r.get("c50_out_db")) is not None and num(r.get("c50_in_db")) is not None else None) for r in ok]  # fmt: skip
    noises = distinct(ok, "noise")
    names = _enhancers(ok)
    colours, markers = _colours(names), _markers(names)
    fig, axes = new_figure(len(panels), len(noises), figsize=(3.8 * len(noises) + 0.4, 3.2 * len(panels) + 0.5),
                             squeeze=False)  # fmt: skip
    for j, noise in enumerate(noises):
        for name in names:
            mine = [r for r in ok if r["noise"] == noise and r["enhancer"] == name]
            kw = dict(color=colours[name], marker=markers[name], label=name)
            for i, (y_f, _) in enumerate(panels):
                if x_is_key:
                    _errorbar(axes[i, j], _seed_points(mine, x_f, y_f), **kw)
                    continue
                xv, yv = seed_means(mine, x_f), seed_means(mine, y_f)
                (xm, xlo, xhi), (ym, ylo, yhi) = seed_interval(xv, x_f), seed_interval(yv, y_f)
                if xm is None or ym is None:
                    continue
                axes[i, j].errorbar([xm], [ym], xerr=[[xm - xlo], [xhi - xm]], yerr=[[ym - ylo], [yhi - ym]],
                                    capsize=2, ls="none", **kw)  # fmt: skip
                _mark_clipped(axes[i, j], [(xm, ylo, yhi)] if interval_clipped(yv, y_f) else [])
                _mark_clipped(axes[i, j], [(ym, xlo, xhi)] if interval_clipped(xv, x_f) else [], vertical=False)
        axes[0, j].set_title(str(noise), fontsize=10)
        for i, (_, y_label) in enumerate(panels):
            axes[i, j].set(xlabel=x_label, ylabel=y_label)
            axes[i, j].grid(True, alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if handles:
        axes[0, 0].legend(handles, labels, fontsize=7, loc="best", ncol=2 if len(labels) > 5 else 1)
    what = "against RT60" if x_is_key else "quality against SNR-I"
    keys = ("noise", "enhancer", x_f) if x_is_key else ("noise", "enhancer")
    fig.suptitle(f"{len(names)} systems, {what}, per noise: mean over each seed's conditions; "
                 f"{n_words(seed_counts(ok, keys))}", fontsize=9)  # fmt: skip
    fig.tight_layout()
    return [save_figure(fig, out_dir / "overview.png")]


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
    fig, ax = new_figure(figsize=(8, 3.4))
    drawn = 0
    for key, rec in sorted(trace.items()):
        values = [v if v is not None else math.nan for v in rec.get("values", [])]
        step = num(rec.get("step_s")) or 1.0
        if values:
            ax.plot([i * step for i in range(len(values))], values, lw=1, label=key)
            drawn += 1
    if not drawn:
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
