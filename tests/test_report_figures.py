"""Every figure of every preset's report, rendered small from rows shaped like the preset's,
with its titles and legends checked against the rows it draws (issue 20 part 3)."""

from __future__ import annotations

import json
import math

import matplotlib.figure
import pytest

from benchmarks.report import figures
from benchmarks.report.core import write_report
from benchmarks.report.listening import ListenOptions
from benchmarks.report.tables import drawn_keys
from benchmarks.run.sweep import PRESETS, load_sweep, stratified
from benchmarks.thesis import reference as T

N_SEEDS = 2


def _enhancers(name: str) -> tuple[str, ...]:
    return load_sweep(name).enhancers


def _preset_rows(name: str) -> list[dict]:
    """Rows with the preset's conditions (2 seeds, a stratified subset) and made-up metrics:
    system k gains 2k dB, loses 1 dB per second of RT60; each seed shifts by 0.5."""
    sweep = load_sweep(name).with_seeds(N_SEEDS)
    conds = sweep.conditions()
    n = min(len(conds), max(12, 2 * max((len(sweep.axes[a]) for a in sweep.swept_axes), default=1)))
    conds = stratified(conds, n, sweep.swept_axes)
    rows = []
    for cond in conds:
        target = "early50" if cond.reference != "direct" else ("direct" if cond.room_dims_m is not None else None)
        for k, enh in enumerate(sweep.enhancers):
            snr_i = 2.0 * k - cond.rt60_s + 0.5 * cond.seed
            rows.append(dict(
                condition_id=cond.id, condition_json=cond.to_json(), enhancer=enh, noise=cond.noise,
                snr_in_db=cond.snr_db, rt60_s=cond.rt60_s, speech_az_deg=cond.speech_az_deg,
                noise_az_deg=cond.noise_az_deg, distance_m=cond.distance_m, seed=cond.seed,
                noise_field=cond.noise_field, far_field=int(cond.far_field), spacing_m=cond.spacing_m,
                ideal_sensors=int(cond.ideal_sensors), metric_target=target, status="ok",
                snr_i_db=snr_i, snr_i_hagerman_db=snr_i - 0.2, snr_out_db=cond.snr_db + snr_i,
                pesq_nb_raw_in=1.5, pesq_nb_raw_out=1.5 + 0.1 * k, pesq_nb_in=1.4, pesq_nb_out=1.4 + 0.1 * k,
                pesq_wb_out=1.3 + 0.1 * k, stoi_in=0.8, stoi_out=0.8 + 0.01 * k,
                sinr_i_db=snr_i - 1.0, c50_in_db=5.0, c50_out_db=5.0 + k, drr_in_db=2.0, drr_out_db=2.0 + k,
                srmr_in=4.0, srmr_out=4.0 + 0.1 * k, t30_s=cond.rt60_s, edt_s=cond.rt60_s,
                snr_i_octave_json=json.dumps({"centre_hz": [250, 500, 1000],  # the input: 0 dB in every band
                                              "snr_i_db": [0.0] * 3 if enh == "passthrough" else [k + 1, 2.0, 0.5]}),
                speech_jitter_db=-math.inf if k % 3 == 1 else -20.0, hagerman_leak_db=-10.0,
                trace_json=json.dumps({"beta": {"step_s": 0.01, "values": [0.1, 0.5, 0.9]}})
                if T.base_name(enh) == "eb" else None,
            ))  # fmt: skip
    return rows


def _styles(fig) -> list[tuple[str, tuple[str, str]]]:
    """``(label, (colour hex, marker))`` of every labelled line and error-bar series of ``fig``
    (a label's text before " (" or "," is the system's name)."""
    from matplotlib.colors import to_hex

    out = []
    for ax in fig.axes:
        lines = [(c.get_label(), c.lines[0]) for c in ax.containers if hasattr(c, "has_xerr")]
        lines += [(ln.get_label(), ln) for ln in ax.lines]
        for label, line in lines:
            if label and not label.startswith("_") and line is not None:
                name = label.split(" (")[0].split(",")[0]
                out.append((name, (to_hex(line.get_color()), str(line.get_marker()))))
    return out


@pytest.fixture
def drawn(monkeypatch):
    """Render at a reduced resolution and record every saved figure's titles and legends."""
    monkeypatch.setattr(figures, "DPI", 30)
    seen: dict[str, dict] = {}
    original = matplotlib.figure.Figure.savefig

    def savefig(fig, path, *args, **kwargs):
        original(fig, path, *args, **kwargs)
        legends = [lg for lg in [*fig.legends, *(ax.get_legend() for ax in fig.axes)] if lg is not None]
        renderer = fig.canvas.get_renderer()
        seen[str(path).rsplit("/", 1)[-1]] = {
            "suptitle": fig._suptitle.get_text() if fig._suptitle else "",
            "titles": [ax.get_title() for ax in fig.axes if ax.get_visible()],
            "labels": [t.get_text() for lg in legends for t in lg.get_texts()],
            "inside": all(fig.bbox.contains(*lg.get_window_extent(renderer).p0)
                          and fig.bbox.contains(*lg.get_window_extent(renderer).p1) for lg in legends),
            "texts": [t.get_text() for ax in fig.axes for t in ax.texts],
            "styles": _styles(fig),
            "xlabels": [ax.get_xlabel() for ax in fig.axes if ax.get_visible() and ax.name != "polar"],
            "ylabels": [ax.get_ylabel() for ax in fig.axes if ax.get_visible() and ax.name != "polar"],
        }

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    return seen


@pytest.mark.parametrize("preset", [p for p in PRESETS if p != "smoke"])
def test_every_figure_of_a_preset_is_titled_from_its_rows(preset, drawn, tmp_path):
    rows = _preset_rows(preset)
    write_report(rows, tmp_path, listen=ListenOptions(count=0))
    names = T.system_order({r["enhancer"] for r in rows})
    noises = sorted({r["noise"] for r in rows})
    assert "overview.png" in drawn
    for fname, fig in drawn.items():
        text = " ".join([fig["suptitle"], *fig["titles"]])
        assert fig["inside"], (fname, "a legend leaves the canvas")
        assert "ours solid" not in text  # no fixed title
        assert all(fig["xlabels"]) and all(fig["ylabels"]), (fname, "an axis without a label")
        # every legend entry is a system of these rows, a thesis curve, or a described line
        systems = [lab for lab in fig["labels"] if lab.split(",")[0] in names]
        assert systems or not fig["labels"] or fname in ("beta_trajectory.png", "rt60_achieved.png",
                                                         "mismatch_snr_i.png", "mismatch_pesq.png"), (fname, fig["labels"])  # fmt: skip
        if "seeds" in fig["suptitle"] and "interval" not in fig["suptitle"].replace("95 % t-interval", ""):
            assert f"{N_SEEDS} seeds" in fig["suptitle"] or "seed(s)" in fig["suptitle"], (fname, fig["suptitle"])
    over = drawn["overview.png"]
    assert over["suptitle"].startswith(f"{len(names)} systems")
    # the caption's n is the seeds each drawn point holds (oracle: counted here from the rows)
    x_key = ("rt60_s",) if any(r["metric_target"] for r in rows) and len({r["rt60_s"] for r in rows}) > 1 else ()
    per_point = {}
    for r in rows:
        per_point.setdefault((r["noise"], r["enhancer"], *(r[k] for k in x_key)), set()).add(r["seed"])
    lo, hi = min(map(len, per_point.values())), max(map(len, per_point.values()))
    expected = f"n = {lo}–{hi} seeds per point" if lo != hi else "1 seed, no interval" if lo == 1 else f"over {lo} seeds"
    assert expected in over["suptitle"], over["suptitle"]
    assert sorted(over["titles"][: len(noises)]) == noises
    assert sorted(set(over["labels"])) == sorted(names)
    # a figure per noise present wherever the per-SNR figures are drawn, each titled by its noise
    per_noise = {f: d for f, d in drawn.items() if f.startswith("snr_pesq_vs_input_snr_")}
    for fname, fig in per_noise.items():
        noise = fname.removeprefix("snr_pesq_vs_input_snr_").removesuffix(".png")
        assert fig["suptitle"].startswith(f"{noise}: ")
        thesis = any(T.is_thesis_condition(r) for r in rows if r["noise"] == noise)
        assert ("thesis' printed values dashed" in fig["suptitle"]) == thesis
    if per_noise:
        generic_noises = {f.removeprefix("snr_pesq_vs_input_snr_").removesuffix(".png") for f in per_noise}
        assert generic_noises == {r["noise"] for r in rows if not r["metric_target"]}
    # per-octave SNR-I: one figure per noise, the input (passthrough, 0 dB in every band) not drawn,
    # the linear bound only beside fixed systems (jitter -inf: k % 3 == 1 above), naming them
    octave = {f: d for f, d in drawn.items() if f.startswith("octave_snr_i_")}
    assert set(octave) == {f"octave_snr_i_{n}.png" for n in noises}
    for fig in octave.values():
        assert "passthrough" not in [lab for lab, _ in fig["styles"]]
        bounds = [lab for lab in fig["labels"] if lab.startswith("LTI bound")]
        fixed = [n for k, n in enumerate(_enhancers(preset)) if k % 3 == 1]
        assert all(set(b[b.index("(") + 1:-1].split(", ")) <= set(fixed) for b in bounds), bounds
    # polar plots only over swept azimuths
    if "snr_i_vs_noise_azimuth.png" in drawn:
        assert not all("noise_az_deg" in drawn_keys(r) for r in rows)
    _check_in_browser(tmp_path / "report")
    _STYLES_SEEN[preset] = {lab: st for fig in drawn.values() for lab, st in fig["styles"] if lab in names and st}


#: Legend styles per preset's report, filled by the test above; checked across reports below.
_STYLES_SEEN: dict[str, dict] = {}


def test_every_system_has_one_style_in_every_report(drawn, tmp_path):
    """Each system keeps one (colour, marker) in every figure of every preset's report, and no two
    systems share one (oracle: the legends of the drawn figures, against :func:`figures.system_style`)."""
    import enhancers

    for preset in ("phone", "peers", "reverb", "thesis-text"):
        if preset not in _STYLES_SEEN:
            drawn.clear()
            write_report(_preset_rows(preset), tmp_path / preset, listen=ListenOptions(count=0))
            names = {r["enhancer"] for r in _preset_rows(preset)}
            _STYLES_SEEN[preset] = {lab: st for fig in drawn.values() for lab, st in fig["styles"] if lab in names and st}
    seen: dict[str, set] = {}
    for styles in _STYLES_SEEN.values():
        for name, style in styles.items():
            seen.setdefault(name, set()).add(style)
    assert len(seen) >= 10 and all(len(v) == 1 for v in seen.values()), {k: v for k, v in seen.items() if len(v) > 1}
    by_style = {next(iter(v)): k for k, v in seen.items()}
    assert len(by_style) == len(seen), "two systems share a style"
    from matplotlib.colors import to_hex

    for name, style in seen.items():
        colour, marker = figures.system_style(name)
        assert next(iter(style)) == (to_hex(colour), marker), name
    # every registered name has its own style; >= 16 distinct colours among the first 16
    registered = enhancers.available()
    assert set(registered) <= set(figures.KNOWN_SYSTEMS)
    assert len({figures.system_style(n) for n in figures.KNOWN_SYSTEMS}) == len(figures.KNOWN_SYSTEMS)
    assert len({figures.system_style(n)[0] for n in figures.KNOWN_SYSTEMS[:16]}) == 16


def _check_in_browser(report):
    """The preset's page in headless Chromium (when installed): no console errors, every
    contents link resolves, every figure loads."""
    from headless_browser import find_chromium, inspect_page

    binary = find_chromium()
    if binary is None:
        return
    seen = inspect_page((report / "index.html").as_uri(), binary=binary)
    assert seen.console_errors == []
    assert seen.links and all(link["resolves"] for link in seen.links), seen.links
    assert seen.images and all(i["complete"] and i["naturalWidth"] > 0 for i in seen.images), seen.images


@pytest.mark.parametrize(("outlier", "marked"), [(0.2, True), (0.97, False)])
def test_clipped_intervals_are_marked(outlier, marked, drawn, tmp_path):
    # Oracle: STOI of five seeds 0.99, 0.99, 0.99, 0.99, x; with x = 0.2 the t-interval
    # (0.83 +- 0.44) leaves [0, 1] and is clipped, with x = 0.97 it stays inside.
    from benchmarks.report import figures

    rows = [dict(enhancer="eb", noise="babble", seed=s, snr_in_db=0.0, snr_i_db=1.0 + s, pesq_nb_raw_out=2.0,
                 stoi_out=outlier if s == 4 else 0.99) for s in range(5)]  # fmt: skip
    figures.overview_figure(rows, tmp_path)
    note = "× interval clipped to the metric's range"
    assert (note in drawn["overview.png"]["texts"]) == marked
