"""report/index.html: Markdown to HTML, the choice of conditions, loudness matching, the
re-render from the store, and the page in a real headless Chromium."""

from __future__ import annotations

import os
import re
import shutil
import sqlite3
import tempfile
from pathlib import Path

import numpy as np
import pytest
from _bench_smoke import local_smoke_run
from headless_browser import inspect_page

from benchmarks.cli.main import main
from benchmarks.metrics import speech as M
from benchmarks.report.html import markdown_to_html, write_index
from benchmarks.report.listening import (
    TARGET_LEVEL_DBFS,
    ListenOptions,
    choose_conditions,
    listen_for,
    match_loudness,
    render_condition,
)
from benchmarks.store.sqlite import ResultStore
from scenesim.errors import ParameterError
from scenesim.scene.mixing import active_speech_power

#: Where the browser test keeps its screenshot (a temporary folder, never the repository);
#: ``$SCENESIM_ARTIFACTS`` overrides.
ARTIFACTS = Path(os.environ.get("SCENESIM_ARTIFACTS", Path(tempfile.gettempdir()) / "scenesim-artifacts"))
#: Chromium's <audio>.duration of an Ogg Vorbis clip exceeds the written length by one
#: Vorbis short block (256 samples = 16 ms at 16 kHz: the stream's last page is padded to a
#: block); soundfile reads the exact length back.  30 ms covers that and no more.
DURATION_TOL_S = 0.030


@pytest.fixture(scope="module")
def smoke_copy(tmp_path_factory):
    """A private copy of the session's smoke store (4 conditions x 4 enhancers)."""
    code, out = local_smoke_run(tmp_path_factory)
    assert code == 0
    copy = tmp_path_factory.mktemp("listen")
    shutil.copy(out / "results.sqlite", copy / "results.sqlite")
    return copy


def _rows(out: Path) -> list[dict]:
    with ResultStore.open(out, readonly=True) as store:
        return store.rows()


# -- Markdown and escaping -----------------------------------------------------------------


def test_markdown_to_html_escapes_text_tables_and_image_sources():
    md = "\n".join([
        "# Report <script>alert(1)</script>",
        "",
        "Some **bold** and `code` & \"quotes\" and *why*.",
        "",
        "| system | note |",
        "| --- | --- |",
        "| `eb` | a \\| b <b>x</b> |",
        "",
        "- top",
        "  - nested <i>",
        "- next",
        "",
        "![fig](plot.png)",
        "",
        '![bad](javascript:alert(1))',
    ])  # fmt: skip
    page = markdown_to_html(md)
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "<strong>bold</strong>" in page and "<code>code</code>" in page and "<em>why</em>" in page
    assert "&amp; &quot;quotes&quot;" in page
    assert "<td>a | b &lt;b&gt;x&lt;/b&gt;</td>" in page  # the escaped pipe stays in its cell
    assert page.count("<ul>") == 2 and page.count("</ul>") == 2 and "nested &lt;i&gt;" in page
    assert '<img src="plot.png" alt="fig">' in page
    assert "javascript:" not in re.sub(r"<p>.*?</p>", "", page, flags=re.S)  # only as text


# -- choosing conditions -------------------------------------------------------------------


def test_choose_conditions_spreads_noises_and_snrs():
    rows = [
        {"condition_id": f"{n}-{s}-{seed}", "noise": n, "snr_in_db": s, "seed": seed, "status": "ok"}
        for seed in (1, 0)
        for n in ("wind", "babble", "factory")
        for s in (25, 0, 5, 10, 15, 20)
    ]
    rows.append({"condition_id": "err", "noise": "zzz", "snr_in_db": 0, "seed": 0, "status": "error"})
    six = choose_conditions(rows, count=6)
    # every noise twice, every SNR once, the lowest seed, the extremes of SNR first
    assert sorted(c.split("-")[0] for c in six) == ["babble"] * 2 + ["factory"] * 2 + ["wind"] * 2
    assert sorted(int(c.split("-")[1]) for c in six) == [0, 5, 10, 15, 20, 25]
    assert all(c.endswith("-0") for c in six) and six[0] == "babble-0-0"
    assert choose_conditions(rows, count=0) == []
    assert len(choose_conditions(rows, count=100)) == 18


def test_choose_conditions_spans_rt60_and_distance():
    # The reverb page used to play only RT60 0: with RT60 and distance swept, 4 picks hear
    # every RT60 and both distances, and both noises.
    rows = [{"condition_id": f"{rt}-{d}-{n}-{s}", "rt60_s": rt, "distance_m": d, "noise": n, "snr_in_db": s,
             "seed": 0, "status": "ok"}
            for rt in (0.0, 0.3, 0.6, 0.9) for d in (0.5, 2.0) for n in ("babble", "factory") for s in (0, 10)]  # fmt: skip
    four = [r for c in choose_conditions(rows, count=4) for r in rows if r["condition_id"] == c]
    assert sorted(r["rt60_s"] for r in four) == [0.0, 0.3, 0.6, 0.9]
    assert {r["distance_m"] for r in four} == {0.5, 2.0} and {r["noise"] for r in four} == {"babble", "factory"}


def test_listen_for_names_what_the_condition_tests():
    assert "late reverberation" in listen_for({"noise": "babble", "rt60_s": 0.6, "snr_in_db": 10})
    assert "late reverberation" not in listen_for({"noise": "babble", "rt60_s": 0.0, "snr_in_db": 10})
    assert "wind bursts" in listen_for({"noise": "wind", "rt60_s": 0.0, "snr_in_db": 10})
    assert "musical noise" in listen_for({"noise": "factory", "rt60_s": 0.0, "snr_in_db": 25})


def test_listen_options_are_validated():
    with pytest.raises(ParameterError, match="count"):
        ListenOptions(count=-1)
    with pytest.raises(ParameterError, match="condition_ids"):
        ListenOptions(condition_ids="abc")


# -- loudness ------------------------------------------------------------------------------


def test_match_loudness_gives_equal_active_levels_and_a_common_peak_limit(rng):
    fs = 16000
    t = np.arange(2 * fs) / fs
    burst = np.sin(2 * np.pi * 300 * t) * (np.sin(2 * np.pi * 1.5 * t) > 0)  # on/off "speech"
    signals = {"quiet": 0.01 * burst, "loud": 0.5 * burst + 0.01 * rng.standard_normal(t.size)}
    out, gains = match_loudness(signals, fs)
    for name, y in out.items():
        # oracle: the P.56-style active level recomputed on the output; tolerance 0.01 dB
        level = 10 * np.log10(active_speech_power(y, fs))
        assert level == pytest.approx(TARGET_LEVEL_DBFS, abs=0.01), name
        assert gains[name] == pytest.approx(20 * np.log10(np.max(np.abs(y)) / np.max(np.abs(signals[name]))), abs=1e-9)
    # a clip that would exceed the peak limit lowers every clip by the same factor
    spiky = {"a": burst.copy(), "b": burst.copy()}
    spiky["b"][100] = 50.0
    out, gains = match_loudness(spiky, fs)
    assert max(np.max(np.abs(y)) for y in out.values()) == pytest.approx(0.95, rel=1e-12)
    la, lb = (10 * np.log10(active_speech_power(out[k], fs)) for k in "ab")
    assert la == pytest.approx(lb, abs=0.05) and la < TARGET_LEVEL_DBFS - 1.0


def test_audio_falls_back_to_16_bit_wav_without_vorbis(monkeypatch):
    import soundfile

    from benchmarks.report.listening import audio_format

    monkeypatch.setattr(soundfile, "available_subtypes", lambda fmt=None: {"VORBIS": "Vorbis"})
    assert audio_format() == ("ogg", "OGG", "VORBIS")
    monkeypatch.setattr(soundfile, "available_subtypes", lambda fmt=None: {})
    assert audio_format() == ("wav", "WAV", "PCM_16")


# -- re-rendering from the store -----------------------------------------------------------


def test_rerender_reproduces_the_stored_signals(smoke_copy):
    """Oracle: STOI of the re-rendered signals equals the stored STOI (same signals, same
    pystoi), to 1e-9 -- for the mixture (stoi_in) and for the EB-SS output (stoi_out)."""
    rows = [r for r in _rows(smoke_copy) if r["noise"] == "babble" and r["snr_in_db"] == 0]
    by_name = {r["enhancer"]: r for r in rows}
    signals, fs, notes = render_condition(by_name, data_dir=None, params={})
    assert notes == []
    assert set(signals) == {"reference", "mixture", "eb", "ss", "eb-ss", "passthrough"}
    ref = signals["reference"]
    assert M.stoi_scores(ref, signals["mixture"][: ref.size], fs=fs)["stoi"] == pytest.approx(
        by_name["eb-ss"]["stoi_in"], abs=1e-9
    )
    y, r = M.align(signals["eb-ss"], ref, latency_samples=by_name["eb-ss"]["latency_samples"])
    assert M.stoi_scores(r, y, fs=fs)["stoi"] == pytest.approx(by_name["eb-ss"]["stoi_out"], abs=1e-9)
    np.testing.assert_array_equal(signals["passthrough"], signals["mixture"])


def _page(report_dir: Path) -> str:
    return (report_dir / "index.html").read_text(encoding="utf-8")


def test_missing_data_and_changed_specs_are_said_on_the_page(smoke_copy, tmp_path):
    store_dir = tmp_path / "store"
    store_dir.mkdir()
    shutil.copy(smoke_copy / "results.sqlite", store_dir / "results.sqlite")
    rows = _rows(store_dir)
    cids = list(dict.fromkeys(r["condition_id"] for r in rows))
    for r in rows:
        if r["enhancer"] == "ss":
            r["enhancer_spec"] = r["enhancer_spec"].replace('"alpha": 0.9', '"alpha": 0.5')
    report = tmp_path / "report"
    report.mkdir()
    write_index(report, "# t", rows, store_dir=store_dir, listen=ListenOptions((cids[0], "nosuchid")))
    page = _page(report)
    assert "ss: not played, its stored spec differs" in page
    assert page.count("<audio") == 4  # reference, mixture, eb, eb-ss (passthrough = the mixture)
    assert "passthrough: identical to the input mixture, not repeated" in page
    assert "nosuchid" in page and "no &#x27;ok&#x27; rows with this condition_id" in page

    db = sqlite3.connect(store_dir / "results.sqlite")
    with db:
        db.execute("UPDATE runs SET data_dir = ?", (str(tmp_path / "gone"),))
    db.close()
    write_index(report, "# t", rows, store_dir=store_dir, listen=ListenOptions((cids[0],)))
    page = _page(report)
    assert page.count("<audio") == 0 and not list((report / "audio").glob("*.ogg"))
    assert "DataError" in page and "gone" in page


# -- the page in a real browser ------------------------------------------------------------




def test_page_in_headless_chromium(smoke_copy, chromium, capsys):
    assert main(["bench", "report", str(smoke_copy), "--listen-count", "3"]) == 0
    report = smoke_copy / "report"
    assert str(report / "index.html") in capsys.readouterr().out
    seen = inspect_page((report / "index.html").as_uri(), binary=chromium)
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shot = ARTIFACTS / "report_index.png"
    shot.write_bytes(seen.screenshot_png)
    assert seen.console_errors == []
    # the contents list links every section heading, and every in-page link resolves
    headings = re.findall(r"^## (.+)$", (report / "summary.md").read_text(encoding="utf-8"), flags=re.M)
    assert len(seen.links) >= len(headings) - 1 >= 5  # all but "Contents" itself
    assert all(link["resolves"] for link in seen.links), [lk for lk in seen.links if not lk["resolves"]]
    # 3 conditions x (reference, mixture, 3 systems): passthrough is the mixture, not repeated
    assert len(seen.audio) == 15
    for a in seen.audio:
        assert (report / a["attr"]).is_file(), a
        assert a["error"] is None and a["readyState"] >= 1, a
        assert a["duration"] == pytest.approx(a["expected"], abs=DURATION_TOL_S), a
        assert a["expected"] == pytest.approx(2.0, abs=1e-9)  # the smoke clips are 2 s long
    figures = sorted(p.name for p in report.glob("*.png"))
    assert "overview.png" in figures and sorted(i["src"] for i in seen.images) == figures
    assert all(i["complete"] and i["naturalWidth"] > 0 for i in seen.images), seen.images
    assert seen.screenshot_png[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000


def test_listen_flag_picks_the_conditions(smoke_copy, capsys):
    cid = _rows(smoke_copy)[-1]["condition_id"]
    assert main(["bench", "report", str(smoke_copy), "--listen", cid]) == 0
    page = _page(smoke_copy / "report")
    assert page.count("<audio") == 5 and page.count(f"audio/{cid}_") == 5  # no passthrough: it is the mixture
    assert main(["bench", "report", str(smoke_copy), "--listen-count", "0"]) == 0
    assert "<audio" not in _page(smoke_copy / "report")
