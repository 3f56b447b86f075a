"""Reverberation report sections from synthetic rows (benchmarks/report/reverb.py)."""

import json
import math

import pytest
from scipy import stats

from benchmarks.report.core import write_report
from benchmarks.report.reverb import (
    drr_zero_crossing_m,
    reverb_rows,
    reverb_sections,
    rt60_summary,
    split_studies,
)


def _row(enh, rt60, seed, *, distance, drawn, snr=0.0, noise="babble", target="early50"):
    cond = {"rt60_s": rt60, "seed": seed, "distance_m": distance, "room": "living"}
    if drawn:
        cond["distance_range_m"] = [0.5, 1.2]
    gain = {"eb": 3.0, "passthrough": 0.0}[enh]
    return {
        "enhancer": enh, "status": "ok", "rt60_s": rt60, "seed": seed, "snr_in_db": snr, "noise": noise,
        "distance_m": distance, "metric_target": target, "condition_json": json.dumps(cond),
        "condition_id": f"{rt60}-{seed}-{distance}-{snr}-{noise}", "group_id": f"{rt60}-{seed}-{distance}",
        "sinr_i_db": gain - rt60 + seed, "snr_i_db": gain, "drr_in_db": -rt60, "drr_out_db": -rt60 + gain / 3,
        "c50_in_db": 5.0, "c50_out_db": 5.0 + gain / 2, "srmr_in": 3.0, "srmr_out": 3.0 + gain / 10,
        "t30_s": rt60 * 1.05 if rt60 else None, "edt_s": rt60, "drr_rir_db": 6.0 - 10 * math.log10(distance / 0.4),
        "drr_rir_target_db": 0.0, "c50_rir_db": 3.0, "c50_rir_target_db": 2.0, "critical_distance_m": 0.9,
        "rt60_target_s": rt60,
    }  # fmt: skip


def _rt60_rows():
    return [_row(e, rt, s, distance=0.5 + 0.1 * s, drawn=True, snr=snr, noise=n)
            for e in ("eb", "passthrough") for rt in (0.0, 0.3, 0.6) for s in (0, 1, 2)
            for snr in (0.0, 10.0) for n in ("babble", "factory")]  # fmt: skip


def _distance_rows():
    return [_row(e, rt, s, distance=d, drawn=False) for e in ("eb", "passthrough") for rt in (0.3, 0.8)
            for d in (0.3, 1.0, 3.0) for s in (0, 1)]  # fmt: skip


def test_rt60_summary_mean_and_ci_over_seeds():
    # Oracle: per seed the mean over noises and SNRs is gain - rt60 + seed; over seeds
    # 0, 1, 2 the mean is gain - rt60 + 1, sd 1, CI half-width t(0.975, 2) / sqrt(3).
    summary = rt60_summary(reverb_rows(_rt60_rows()))
    rec = next(r for r in summary if r["enhancer"] == "eb" and r["rt60_s"] == 0.3)
    assert rec["n"] == 3
    assert rec["sinr_i_db"] == pytest.approx(3.0 - 0.3 + 1.0, abs=1e-12)
    assert rec["sinr_i_db_ci95"] == pytest.approx(stats.t.ppf(0.975, 2) / math.sqrt(3), rel=1e-9)
    assert rec["drr_gain_db"] == pytest.approx(1.0, abs=1e-12) and rec["c50_gain_db"] == pytest.approx(1.5, abs=1e-12)


def test_studies_are_split_by_a_swept_distance():
    rt60, dist = split_studies(reverb_rows(_rt60_rows() + _distance_rows()))
    assert len(rt60) == len(_rt60_rows()) and len(dist) == len(_distance_rows())


def test_zero_crossing_closed_form():
    # DRR = 6 - 10 log10(d / 0.4) crosses 0 dB at d = 0.4 * 10^0.6, exactly linear in log d.
    d = [0.3, 1.0, 3.0]
    assert drr_zero_crossing_m(d, [6 - 10 * math.log10(x / 0.4) for x in d]) == pytest.approx(0.4 * 10**0.6, rel=1e-12)
    assert drr_zero_crossing_m(d, [3.0, 2.0, 1.0]) is None


def test_sections_name_the_target_in_every_table_header(tmp_path):
    lines, paths = reverb_sections(_rt60_rows() + _distance_rows(), tmp_path)
    text = "\n".join(lines)
    headers = [ln for ln in lines if ln.startswith("### ")]
    assert headers and all("direct path + first 50 ms" in h for h in headers if "Critical" not in h)
    assert "r_c = 0.057 sqrt(V/RT60)" in text
    names = {p.name for p in paths}
    assert {"reverb_vs_rt60.png", "rt60_achieved.png", "reverb_vs_distance.png", "reverb_rt60.csv"} <= names


def test_write_report_includes_the_reverb_sections(tmp_path):
    write_report(_rt60_rows(), tmp_path)
    summary = (tmp_path / "report" / "summary.md").read_text()
    assert "## Reverberation study: systems vs RT60" in summary
    assert (tmp_path / "report" / "rt60_achieved.png").is_file()
