"""Report sections for real microphones (issue 8): spread over seeds only, mismatch tables, flags."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from benchmarks.report.core import write_report
from benchmarks.report.sensors import HAGERMAN_FLAG_DB, honesty_flags, phone_summary

PHONE_COND = json.dumps({"mic_gain_tol_db": 1.0, "mic_highpass_hz": [100, 100], "mic_highpass_tol_hz": 30,
                         "self_noise_dba": 30, "speech_spl_db": 65, "noise_az_range_deg": [100, 260]})  # fmt: skip


def _phone_row(enhancer, noise, snr, seed, snr_i, **extra):
    return {
        "condition_id": f"{noise}-{snr}-{seed}", "enhancer": enhancer, "noise": noise,
        "noise_field": {"babble": "diffuse", "factory": "point"}[noise], "snr_in_db": float(snr),
        "rt60_s": 0.0, "speech_az_deg": 45.0, "noise_az_deg": 100.0 + 10 * seed if noise == "factory" else None,
        "seed": seed, "snr_i_db": snr_i, "snr_i_hagerman_db": snr_i - 0.5, "snr_out_db": snr + snr_i,
        "snr_out_limit_db": 38.0, "pesq_nb_raw_out": 2.0, "status": "ok", "condition_json": PHONE_COND,
        "ideal_sensors": 0, **extra,
    }  # fmt: skip


def test_phone_summary_spread_is_over_seeds_of_snr_means():
    # Oracle: scipy.stats.t on the per-seed means.  Seed s has SNR-I s + snr/10 at SNRs
    # 0..20: its mean over SNRs is s + 1; the CI is over the 4 seed means, never over SNRs.
    rows = [_phone_row("eb", "babble", snr, seed, seed + snr / 10) for seed in range(4) for snr in (0, 10, 20)]
    rec = phone_summary(rows, ("snr_i_db",))[0]
    per_seed = np.arange(4) + 1.0
    half = stats.t.ppf(0.975, 3) * np.std(per_seed, ddof=1) / 2
    assert rec["n"] == 4
    np.testing.assert_allclose([rec["snr_i_db"], rec["snr_i_db_ci95"]], [per_seed.mean(), half], rtol=1e-12)


def test_phone_summary_uses_only_the_snrs_every_seed_has():
    rows = [_phone_row("eb", "babble", snr, seed, float(snr)) for seed in range(3) for snr in (0, 10)]
    rows.append(_phone_row("eb", "babble", 20, 0, 20.0))  # seed 0 alone has 20 dB
    rec = phone_summary(rows, ("snr_i_db",))[0]
    assert rec["snr_values_db"] == "0 10" and rec["snr_i_db"] == pytest.approx(5.0)


def test_phone_report_section_table_figure_and_no_azimuth_sweep(tmp_path):
    rows = [_phone_row(name, noise, snr, seed, base + seed * 0.3)
            for name, base in (("passthrough", 0.0), ("eb", -2.0), ("eb-ss", 2.0))
            for noise in ("babble", "factory") for snr in (0, 10) for seed in range(3)]  # fmt: skip
    paths = write_report(rows, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "## Realistic phones (sensors drawn per seed)" in text
    assert "the mean over the seeds" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("| `eb` | babble (diffuse)"))
    # 3 seeds (< 5): the seeds' min … max, never a t-interval; SNR-I to one decimal
    assert "| -1.7 (-2.0 … -1.4) |" in line and "| 3 |" in line and "| 13.2 |" in line  # thesis EB babble average 13.18 dB, one decimal
    assert "Noise azimuth sweep" not in text  # drawn azimuths are not a sweep
    assert "No rows at the thesis' conditions" in text
    names = {p.name for p in paths}
    assert {"phone_summary.csv", "phone_by_snr.csv", "phone_vs_thesis.png"} <= names


def _mismatch_row(enhancer, gain, phase, geometry, snr_i):
    cond = {"mic_gain_db": gain, "mic_phase_deg": phase} if (gain or phase) else {}
    field, az = ("diffuse", None) if geometry == "diffuse" else ("point", geometry)
    return {"condition_id": f"{enhancer}-{gain}-{phase}-{geometry}", "enhancer": enhancer, "noise": "babble",
            "noise_field": field, "noise_az_deg": az, "snr_in_db": 5.0, "rt60_s": 0.0, "speech_az_deg": 45.0,
            "seed": 0, "snr_i_db": snr_i, "snr_i_hagerman_db": snr_i, "pesq_nb_raw_out": 2.0, "status": "ok",
            "condition_json": json.dumps(cond), "ideal_sensors": int(not cond)}  # fmt: skip


def test_mismatch_section_tabulates_gain_by_phase(tmp_path):
    rows = [_mismatch_row(e, g, p, geo, 30.0 - 20 * g - 2 * p)
            for e in ("eb", "cardioid") for g in (0.0, 0.5, 1.0) for p in (0.0, 2.0) for geo in (270.0, "diffuse")]  # fmt: skip
    paths = write_report(rows, tmp_path)
    text = (tmp_path / "report" / "summary.md").read_text()
    assert "## Microphone mismatch" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("| point 270° | none | `eb` | 2 |"))
    assert line.endswith("| 26.0 | 16.0 | 6.0 |")  # 30 - 20 g - 4 at g = 0, 0.5, 1
    assert {"mismatch.csv", "mismatch_snr_i.png", "mismatch_pesq.png"} <= {p.name for p in paths}


def test_flags_hagerman_self_noise_and_ideal_outputs():
    ok = [
        {"enhancer": "ss", "snr_i_db": 8.0, "snr_i_hagerman_db": 8.0 - HAGERMAN_FLAG_DB - 0.1, "snr_out_db": 20.0},
        {"enhancer": "eb", "snr_i_db": 8.0, "snr_i_hagerman_db": 8.0 - HAGERMAN_FLAG_DB + 0.1, "snr_out_db": 20.0},
        {"enhancer": "ss", "snr_out_db": 41.0, "snr_out_limit_db": 40.0},
        {"enhancer": "eb", "snr_out_db": 39.0, "snr_out_limit_db": 40.0},
        {"enhancer": "eb", "snr_out_db": 75.0},
    ]  # fmt: skip
    flags = honesty_flags(ok)
    assert flags["hagerman"] == [ok[0]]
    assert flags["above_self_noise"] == [ok[2]]
    assert flags["ideal_high"] == [ok[4]]
