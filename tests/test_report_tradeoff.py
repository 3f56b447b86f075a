"""The ideal-vs-robust trade-off table (issue 16 part 5).  Oracle: means of hand-made rows."""

from __future__ import annotations

import csv

from benchmarks.report.tradeoff import tradeoff_records, tradeoff_section


def _rows():
    out = []
    for system, ideal, snri in (("eb", 1, 40.0), ("eb", 1, 30.0), ("eb", 0, -1.0), ("eb-robust", 1, 25.0),
                                ("eb-robust", 0, 8.0), ("ss", 0, 5.0)):
        out.append({"enhancer": system, "ideal_sensors": ideal, "noise": "babble", "snr_i_db": snri,
                    "pesq_nb_raw_out": 2.0 + ideal, "stoi_out": 0.7})
    out.append({"enhancer": "eb", "ideal_sensors": 1, "noise": "babble", "snr_i_db": 99.0, "metric_target": "c50"})
    return out


def test_table_has_both_systems_with_both_kinds_of_mics(tmp_path):
    """eb ideal = mean(40, 30) = 35 over n = 2; ss and reverberation-target rows are left out; CSV written."""
    recs = {(r["enhancer"], r["mics"]): r for r in tradeoff_records(_rows())}
    assert set(recs) == {("eb", "ideal"), ("eb", "real"), ("eb-robust", "ideal"), ("eb-robust", "real")}
    assert recs[("eb", "ideal")]["snr_i_db"] == 35.0 and recs[("eb", "ideal")]["n"] == 2
    assert recs[("eb-robust", "real")]["pesq_nb_raw_out"] == 2.0
    lines, paths = tradeoff_section(_rows(), tmp_path)
    text = "\n".join(lines)
    assert "| eb | ideal | babble | 2 | 35.00" in text and "| eb-robust | real | babble | 1 | 8.00" in text
    with open(paths[0]) as fh:
        assert len(list(csv.DictReader(fh))) == 4


def test_no_section_without_the_systems(tmp_path):
    assert tradeoff_section([r for r in _rows() if r["enhancer"] == "ss"], tmp_path) == ([], [])
