"""The report: tables, CSVs and figures from synthetic results rows; the thesis loader."""

from __future__ import annotations

import csv
import json

import matplotlib.image as mpimg
import numpy as np
import pytest

from benchmarks.report.core import write_report
from benchmarks.report.tables import aggregate, ci95_halfwidth, mean_std, normalise_rows
from benchmarks.thesis import reference as T

SYSTEMS = ("eb", "ss", "eb-ss")
#: What a row at the thesis' exact conditions records besides the angles (far field, the
#: 2.14 cm pair, ideal sensors, a point noise).
THESIS_ROW = {"far_field": 1, "spacing_m": 0.0214, "ideal_sensors": 1, "noise_field": "point"}
OFFSET_DB = -1.25  # ours = thesis + offset (+- seed spread), so both numbers are distinct


def _row(enhancer, noise, snr, *, rt60=0.0, noise_az=270.0, seed=0, **extra):
    at_thesis = rt60 == 0.0 and noise_az == 270.0
    ref = T.thesis_row(enhancer, noise, snr) if at_thesis else None
    base_i = ref.snr_i_db if ref else 10.0 - 8 * rt60 + 3 * np.cos(np.radians(noise_az))
    spread = 0.5 * (seed - 0.5)
    snr_i = base_i + OFFSET_DB + spread
    row = {
        "condition_id": f"{noise}-{snr}-{rt60}-{noise_az}-{seed}",
        "enhancer": enhancer,
        "noise": noise,
        "snr_in_db": float(snr),
        "rt60_s": rt60,
        "speech_az_deg": 45.0,
        "noise_az_deg": noise_az,
        "seed": seed,
        "snr_in_db_measured": snr + 0.01,
        "snr_out_db": snr + 0.01 + snr_i,
        "snr_i_db": snr_i,
        "pesq_nb_in": 1.5 + snr / 20,
        "pesq_nb_out": 2.0 + snr / 20 + spread / 10,
        "pesq_wb_in": 1.2 + snr / 20,
        "pesq_wb_out": 1.6 + snr / 20,
        "stoi_in": 0.8,
        "stoi_out": 0.85,
        "speech_source": "builtin:artificial-voice",
        "noise_source": f"data:{noise}_noisex.wav",
        "status": "ok",
        "error": None,
        "trace_json": None,
        **THESIS_ROW,
    }
    if enhancer == "eb":
        beta = np.clip(np.linspace(0, 1.2, 500), 0, 1)
        row["trace_json"] = json.dumps({"beta": {"step_s": 0.004, "values": beta.tolist()}})
    row.update(extra)
    return row


@pytest.fixture(scope="module")
def rows():
    out = []
    for enhancer in SYSTEMS:
        for noise in ("babble", "factory"):
            for snr in range(0, 30, 5):
                for seed in (0, 1):
                    out.append(_row(enhancer, noise, snr, seed=seed))
        for rt60 in (0.2, 0.4, 0.6):
            out.append(_row(enhancer, "babble", 10, rt60=rt60))
        for az in range(0, 360, 45):
            if az != 270:
                out.append(_row(enhancer, "babble", 10, noise_az=float(az)))
    out.append(
        _row("ss", "factory", 5, seed=7, status="error", snr_i_db=None, snr_out_db=None,
             pesq_nb_out=None, error="enhancer failed: RuntimeError: boom (at x.py:1 in f)")
    )  # fmt: skip
    out.append(
        _row("eb", "factory", 5, seed=8, pesq_nb_out=None, pesq_wb_out=None,
             error="pesq_out: PESQ (nb) failed: NoUtterancesError: No utterances detected")
    )  # fmt: skip
    return out


@pytest.fixture(scope="module")
def report(rows, tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("sweep")
    paths = write_report(rows, out_dir, meta={"preset": "synthetic"})
    return out_dir, paths


def test_all_files_written_under_report_dir(report):
    out_dir, paths = report
    names = {p.name for p in paths}
    expected = {
        "summary.md", "conditions.csv", "thesis_comparison.csv", "averages.csv",
        "rt60_sweep.csv", "azimuth_sweep.csv", "failures.csv",
        "snr_pesq_vs_input_snr_babble.png", "snr_pesq_vs_input_snr_factory.png",
        "snr_i_vs_rt60.png", "snr_i_vs_noise_azimuth.png", "beta_trajectory.png", "overview.png",
        "verdicts.csv", "ranking.csv",
    }  # fmt: skip
    assert expected <= names
    for p in paths:
        assert p.parent == out_dir / "report" and p.is_file() and p.stat().st_size > 0


def test_figures_are_valid_non_trivial_images(report):
    _, paths = report
    pngs = [p for p in paths if p.suffix == ".png"]
    assert len(pngs) == 6  # the overview and the five the rows support
    for p in pngs:
        img = mpimg.imread(p)
        assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 400
        assert float(np.std(img[..., :3])) > 0.01  # not a blank canvas


def test_summary_puts_thesis_numbers_next_to_ours(report):
    out_dir, _ = report
    text = (out_dir / "report" / "summary.md").read_text()
    # Oracle: thesis table 7.1 (EB, babble, 0 dB): SNR-I 13.8492, PESQ in/out 1.639 / 2.049.
    lines = [ln for ln in text.splitlines() if ln.startswith("| 0 |")]
    eb_babble = text.split("### EB (`eb`), babble — thesis table 7.1")[1].split("###")[0]
    row0 = next(ln for ln in eb_babble.splitlines() if ln.startswith("| 0 |"))
    ours = 13.8492 + OFFSET_DB  # seeds -0.25 / +0.25 average out
    # n = 2 < 5: the seeds' min–max, never the t-interval (t_{.975,1} * std / sqrt(2) = 3.18 dB);
    # dB to one decimal, PESQ to two.
    assert f"{ours:.1f} ({ours - 0.25:.1f} … {ours + 0.25:.1f})" in row0
    assert "±" not in row0 and f"{ci95_halfwidth(np.std([-0.25, 0.25], ddof=1), 2):.2f}" == "3.18"
    assert "| 13.8 |" in row0 and "| 1.64 |" in row0 and "| 2.05 |" in row0
    assert len(lines) >= 6  # one 0 dB line per system x noise
    # Headline: EB-SS averages from tables 7.7/7.8 and the claimed 17 / 22 dB.
    assert "thesis 17 / 22 dB" in text
    assert f"{17.382333 + OFFSET_DB:.1f} / {22.381833 + OFFSET_DB:.1f} dB" in text
    assert "RT60 sweep" in text and "Noise azimuth sweep" in text
    assert "1 × enhancer failed: RuntimeError: boom" in text
    assert "`pesq_out`: 1 ×" in text
    assert "data:babble_noisex.wav" in text and "synthetic" in text


def test_csv_tables_hold_means_and_thesis_columns(report):
    out_dir, _ = report
    with open(out_dir / "report" / "thesis_comparison.csv") as fh:
        recs = list(csv.DictReader(fh))
    # 3 systems x 2 noises x 6 SNRs (the extra seeds 7/8 at factory 5 dB join their condition).
    assert len(recs) == 36
    rec = next(
        r
        for r in recs
        if (r["enhancer"], r["noise"], r["snr_in_db"]) == ("eb-ss", "factory", "25.0")
    )
    np.testing.assert_allclose(float(rec["thesis_snr_i_db"]), 15.617, atol=1e-12)
    np.testing.assert_allclose(float(rec["snr_i_db"]), 15.617 + OFFSET_DB, atol=1e-9)
    assert rec["thesis_table"] == "7.8" and rec["n"] == "2"
    with open(out_dir / "report" / "rt60_sweep.csv") as fh:
        rt = list(csv.DictReader(fh))
    assert sorted({float(r["rt60_s"]) for r in rt}) == [0.0, 0.2, 0.4, 0.6]


def test_report_with_only_errors_or_no_rows(tmp_path):
    bad = [_row("eb", "babble", 0, status="error", error="enhancer failed: X")]
    paths = write_report(bad, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "No results at the thesis geometry." in text and "1 × enhancer failed: X" in text
    assert not [p for p in paths if p.suffix == ".png"]
    write_report([], tmp_path / "empty")
    assert (tmp_path / "empty" / "report" / "summary.md").is_file()


def test_aggregation_and_normalisation():
    # Oracle: arithmetic -- mean/sample std of 1, 2, 3 are 2 and 1; None/NaN are skipped.
    assert mean_std([1, 2, 3, None, float("nan")]) == (2.0, 1.0, 3)
    assert mean_std([None]) == (None, None, 0)
    rows = normalise_rows(
        [{"enhancer": "a", "rt60_s": None, "pesq_nb_out": 3.0, "pesq_nb_in": 2.5, "status": None}]
    )
    assert rows[0]["rt60_s"] == 0.0 and rows[0]["status"] == "ok"
    np.testing.assert_allclose(rows[0]["pesq_nb_i"], 0.5, atol=1e-12)
    agg = aggregate(rows * 2, ("enhancer",), ("pesq_nb_i",))
    assert agg[0]["n"] == 2 and agg[0]["pesq_nb_i_std"] == 0.0


def test_thesis_loader_rows_and_headline():
    rows = T.load_thesis_tables()
    assert len(rows) == 54 and {r.system for r in rows} == {"EB", "SS", "EB-SS"}
    # Oracle: the thesis' abstract -- EB-SS average SNR-I 17 / 22 / 18 dB.
    avg = T.thesis_averages()
    got = [avg[("EB-SS", n)]["snr_i_db"] for n in T.THESIS_NOISES]
    np.testing.assert_allclose(got, [17.382333, 22.381833, 18.621167], atol=1e-6)
    assert [int(g) for g in got] == [17, 22, 18]  # the abstract truncates
    assert T.thesis_row("eb", "wind", 25).pesq_out == 3.705
    assert T.thesis_row("passthrough", "wind", 25) is None
    assert T.is_thesis_condition(
        {"rt60_s": None, "speech_az_deg": 45, "noise_az_deg": -90, "noise": "wind", **THESIS_ROW}
    )
    assert not T.is_thesis_condition(
        {"rt60_s": 0.3, "speech_az_deg": 45, "noise_az_deg": 270, "noise": "wind", **THESIS_ROW}
    )


@pytest.mark.parametrize(
    "change",
    [{"far_field": 0}, {"spacing_m": 0.02}, {"ideal_sensors": 0}, {"far_field": None},
     {"ideal_sensors": None, "condition_json": json.dumps({"mic_gain_db": 0.5})}],
)  # fmt: skip
def test_only_the_thesis_geometry_with_ideal_sensors_is_a_thesis_condition(change):
    # Regression: the near-field reverb/angles rows used to be labelled "thesis table 7.1".
    row = {"rt60_s": 0.0, "speech_az_deg": 45, "noise_az_deg": 270, "noise": "babble", **THESIS_ROW}
    assert T.is_thesis_condition(row)
    assert not T.is_thesis_condition({**row, **change})


def test_thesis_condition_read_from_condition_json_when_columns_are_absent():
    base = {"rt60_s": 0.0, "speech_az_deg": 45, "noise_az_deg": 270, "noise": "babble"}
    cond = {"far_field": True, "spacing_m": 0.0214, "noise_field": "point"}
    assert T.is_thesis_condition({**base, "condition_json": json.dumps(cond)})
    assert not T.is_thesis_condition({**base, "condition_json": json.dumps({**cond, "far_field": False})})


def test_versioned_names_warnings_and_negative_zero(tmp_path):
    rows = [
        _row("eb-ss@1", "babble", snr, warnings="UserWarning: noise 'babble' synthesized")
        for snr in (0, 5)
    ]
    rows.append(_row("passthrough", "babble", 0, snr_i_db=-1e-12, snr_cross_ratio=-0.39))
    write_report(rows, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "### EB-SS (`eb-ss@1`), babble — thesis table 7.7" in text
    assert "**Headline (EB-SS average SNR-I, babble, ideal sensors):**" in text
    assert "2 × UserWarning: noise 'babble' synthesized" in text
    assert "-0.00" not in text
    assert "output power): **1**." in text and "  - passthrough: 1 rows" in text


def test_diffuse_noise_is_not_a_thesis_condition():
    row = {"rt60_s": 0.0, "speech_az_deg": 45, "noise_az_deg": 270, "noise": "babble", **THESIS_ROW}
    assert T.is_thesis_condition({**row, "noise_field": "point"})
    assert not T.is_thesis_condition({**row, "noise_field": "diffuse"})


def test_thesis_report_explains_why_the_eb_exceeds_the_printed_tables(tmp_path):
    rows = [
        dict(condition_id=f"c{snr}", enhancer=name, noise="babble", snr_in_db=snr, rt60_s=0.0,
             speech_az_deg=45.0, noise_az_deg=270.0, seed=0, snr_out_db=snr + 30.0, snr_i_db=30.0,
             pesq_nb_in=1.5, pesq_nb_out=4.0, pesq_wb_in=1.2, pesq_wb_out=3.5, stoi_in=0.8,
             stoi_out=0.99, speech_source="artificial-voice", noise_source="synthetic:babble",
             status="ok", error=None, **THESIS_ROW)
        for snr in (0, 5) for name in ("eb", "passthrough")
    ]
    write_report(rows, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "Reading the comparison" in text
    # Without an EB system there is nothing to explain.
    write_report([r for r in rows if r["enhancer"] == "passthrough"], tmp_path / "pt")
    assert "Reading the comparison" not in (tmp_path / "pt" / "report" / "summary.md").read_text()
