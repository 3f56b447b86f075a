"""``benchmarks.studies.heldout_targets``'s tables from synthetic rows whose answers are known in closed form."""

from __future__ import annotations

import numpy as np
import pandas as pd

from benchmarks.studies.heldout_targets import jitter_lines, paired_lines


def _rows(disagree=1.0):
    rows = []
    for i in range(10):
        for name, snr, pesq, jit in (("eb-robust@1", 3.0, 2.0, -25.0), ("eb-spp", 3.0 - 0.5 + 0.1 * (i % 2), 2.0,
                                                                          -35.0 if i else -19.0)):
            rows.append(dict(enhancer=name, noise="babble", condition_id=f"c{i}", snr_i_db=snr,
                             snr_i_hagerman_db=snr + (4.0 if (name == "eb-spp" and i == 3) else 0.0) * disagree,
                             pesq_nb_out=pesq, speech_jitter_db=jit))
    return pd.DataFrame(rows)


def test_jitter_table_counts_rows_and_judges_the_worst():
    line = [ln for ln in jitter_lines(_rows(), ["eb-spp"]) if ln.startswith("| eb-spp")][0]
    # 9 of 10 rows at -35 dB, one at -19 dB (above -20: the target fails), one of 10 disagreeing by 4 dB
    assert line == "| eb-spp | 10 | 90% | -19.0 | -35.0 | 90% | no |"
    # all agreeing: the worst row alone fails it
    line = [ln for ln in jitter_lines(_rows(0.0), ["eb-spp"]) if ln.startswith("| eb-spp")][0]
    assert line.endswith("| 100% | no |")


def test_paired_bound_is_the_student_t_bound():
    """Differences -0.5, -0.4 alternating: mean -0.45, sd 0.0527, t(0.975, 9) = 2.262: bound -0.488."""
    d = np.array([-0.5, -0.4] * 5)
    low = d.mean() - 2.2621571628 * d.std(ddof=1) / np.sqrt(10)
    line = [ln for ln in paired_lines(_rows(), ["eb-robust@1", "eb-spp"]) if "eb-spp |" in ln][0]
    assert f"-0.45 ({low:+.2f})" in line and line.endswith("SNR-I >= -1: met |")


def test_mvdr_is_held_to_superdirective_at_zero():
    """An adaptive MVDR 0.05 dB above the fixed design in every condition: the bound is +0.05 > 0 (met);
    0.05 dB below: -0.05 < 0 (NOT met) -- the 'not by standing still' target of issue 31."""
    for delta, verdict in ((0.05, "met"), (-0.05, "NOT met")):
        rows = [dict(enhancer=name, noise="factory", condition_id=f"c{i}", snr_i_db=2.0 + d, snr_i_hagerman_db=2.0,
                     pesq_nb_out=2.0, speech_jitter_db=-40.0)
                for i in range(6) for name, d in (("superdirective", 0.0), ("mvdr", delta))]
        (line,) = [ln for ln in paired_lines(pd.DataFrame(rows), ["superdirective", "mvdr"])
                   if "| superdirective |" in ln]
        assert f"{delta:+.2f} ({delta:+.2f})" in line and line.endswith(f"SNR-I >= 0: {verdict} |")
