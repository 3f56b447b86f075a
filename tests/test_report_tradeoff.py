"""The ideal-vs-robust trade-off table (issue 16 part 5).  Oracle: means of hand-made rows,
each seed's mean over its input SNRs first, then over seeds (n = seeds, never SNRs)."""

from __future__ import annotations

import csv

from benchmarks.report.tradeoff import tradeoff_records, tradeoff_section


def _rows():
    out = []
    for system, ideal, seed, snri in (("eb", 1, 0, 40.0), ("eb", 1, 0, 44.0), ("eb", 1, 1, 30.0),
                                      ("eb", 0, 0, -1.0), ("eb-robust", 1, 0, 25.0),
                                      ("eb-robust", 0, 0, 8.0), ("ss", 0, 0, 5.0)):
        out.append({"enhancer": system, "ideal_sensors": ideal, "noise": "babble", "seed": seed,
                    "snr_i_db": snri, "pesq_nb_raw_out": 2.0 + ideal, "stoi_out": 0.7})
    out.append({"enhancer": "eb", "ideal_sensors": 1, "noise": "babble", "snr_i_db": 99.0, "metric_target": "c50"})
    return out


def test_table_has_both_systems_with_both_kinds_of_mics(tmp_path):
    """eb ideal = mean(mean(40, 44), 30) = 36 over n = 2 seeds (not 3 rows); ss and
    reverberation-target rows are left out; n < 5 shows the seeds' min … max; CSV written."""
    recs = {(r["enhancer"], r["mics"]): r for r in tradeoff_records(_rows())}
    assert set(recs) == {("eb", "ideal"), ("eb", "real"), ("eb-robust", "ideal"), ("eb-robust", "real")}
    assert recs[("eb", "ideal")]["snr_i_db"] == 36.0 and recs[("eb", "ideal")]["n"] == 2
    assert recs[("eb-robust", "real")]["pesq_nb_raw_out"] == 2.0
    lines, paths = tradeoff_section(_rows(), tmp_path)
    text = "\n".join(lines)
    assert "| eb | ideal | babble | 2 | 36.0 (30.0 … 42.0) |" in text and "| eb-robust | real | babble | 1 | 8.0 |" in text
    with open(paths[0]) as fh:
        assert len(list(csv.DictReader(fh))) == 4


def test_no_section_without_the_systems(tmp_path):
    assert tradeoff_section([r for r in _rows() if r["enhancer"] == "ss"], tmp_path) == ([], [])
    # eb alone (e.g. the thesis presets) is no trade-off: no section either
    assert tradeoff_section([r for r in _rows() if r["enhancer"] == "eb"], tmp_path) == ([], [])
