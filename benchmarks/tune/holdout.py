"""Dev against test: the optimism of a tuned system, with a bootstrap interval over units.

The search scores parameters on ``dev`` rows and keeps the best, so its dev score is biased
upwards (the winner's curse); the chosen parameters run once on ``test`` material with other
seeds measure it.  Per metric the report gives the dev mean, the test mean, the optimism
``dev - test`` and its 95 % interval from a seeded cluster bootstrap: the rows are grouped into
units ``(speech_source, seed)`` (the rows of one utterance and seed share their speech and
noise draws, so they are not independent); each replicate draws dev units and test units with
replacement, independently (the two sets share no seed), and takes the difference of their
row means.  Non-finite values (a jitter of ``-inf`` dB: no jitter at all) are left out of the
means, and the table says how many rows each mean has.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

REPORT_METRICS = ("snr_i_db", "snr_i_hagerman_db", "pesq_nb_i", "stoi_i", "speech_jitter_db")
"""Metrics every dev/test report shows, beside the objective's and the constraints' columns."""
N_BOOT = 2000
CONFIDENCE = 0.95


def unit_sums(rows: Sequence[Mapping[str, Any]], column: str) -> tuple[np.ndarray, np.ndarray]:
    """Per unit ``(speech_source, seed)``: the sum and count of ``column``'s finite values
    over ok rows, as two float arrays of shape ``(n_units,)`` (units without a value left out).

    >>> s, n = unit_sums([{"status": "ok", "seed": 0, "speech_source": "a", "x": 1.0},
    ...                   {"status": "ok", "seed": 0, "speech_source": "a", "x": 3.0},
    ...                   {"status": "ok", "seed": 1, "speech_source": "a", "x": 5.0}], "x")
    >>> s.tolist(), n.tolist()
    ([4.0, 5.0], [2.0, 1.0])
    """
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        v = r.get(column)
        if r.get("status") == "ok" and v is not None and np.isfinite(float(v)):
            groups.setdefault((r.get("speech_source"), r.get("seed")), []).append(float(v))
    sums = np.array([sum(v) for v in groups.values()], dtype=np.float64)
    return sums, np.array([len(v) for v in groups.values()], dtype=np.float64)


def optimism_interval(dev: tuple[np.ndarray, np.ndarray], test: tuple[np.ndarray, np.ndarray], *,
                      seed: int = 0, n_boot: int = N_BOOT) -> tuple[float, float]:
    """The ``CONFIDENCE`` percentile interval of ``mean(dev) - mean(test)`` over ``n_boot``
    cluster-bootstrap replicates (units drawn with replacement, each side on its own).

    Two sides of one unit each and equal values have no spread:

    >>> optimism_interval((np.array([2.0]), np.array([1.0])), (np.array([1.0]), np.array([1.0])))
    (1.0, 1.0)
    """
    rng = np.random.default_rng(seed)

    def replicates(sums, counts):
        idx = rng.integers(0, sums.size, size=(n_boot, sums.size))
        return sums[idx].sum(axis=1) / counts[idx].sum(axis=1)

    diff = replicates(*dev) - replicates(*test)
    tail = 100.0 * (1.0 - CONFIDENCE) / 2.0
    lo, hi = np.percentile(diff, [tail, 100.0 - tail])
    return float(lo), float(hi)


def dev_test_table(dev_rows, test_rows, metrics: Sequence[str], *, seed: int = 0) -> list[dict[str, Any]]:
    """One dict per metric with values on both sides: dev and test means, row and unit counts,
    ``optimism = dev - test`` and its bootstrap interval (``seed`` seeds the bootstrap)."""
    table = []
    for m in dict.fromkeys(metrics):
        dev, test = unit_sums(dev_rows, m), unit_sums(test_rows, m)
        if not dev[0].size or not test[0].size:
            continue
        d, t = dev[0].sum() / dev[1].sum(), test[0].sum() / test[1].sum()
        lo, hi = optimism_interval(dev, test, seed=seed)
        table.append({"metric": m, "dev": float(d), "test": float(t), "optimism": float(d - t),
                      "ci_lo": lo, "ci_hi": hi, "dev_rows": int(dev[1].sum()), "test_rows": int(test[1].sum()),
                      "dev_units": int(dev[0].size), "test_units": int(test[0].size)})
    return table


def write_report(out_dir: str | Path, table: Sequence[Mapping[str, Any]], header: Sequence[str],
                 constraint_lines: Sequence[str] = ()) -> tuple[Path, Path]:
    """``tune_report.md`` (the header lines, the dev/test table, the constraints) and ``tune_report.csv``."""
    out = Path(out_dir)
    lines = ["# Tuning: dev against test", "", *header, "",
             "| metric | dev | test | optimism (dev - test) | 95 % CI | rows dev / test | units dev / test |",
             "| --- | ---: | ---: | ---: | --- | ---: | ---: |"]
    for r in table:
        lines.append(f"| {r['metric']} | {r['dev']:.3f} | {r['test']:.3f} | {r['optimism']:+.3f} | "
                     f"[{r['ci_lo']:+.3f}, {r['ci_hi']:+.3f}] | {r['dev_rows']} / {r['test_rows']} | "
                     f"{r['dev_units']} / {r['test_units']} |")
    if constraint_lines:
        lines += ["", "Constraints (worst violation over the selected rows; <= 0: met):", "", *constraint_lines]
    lines += ["", "Units are (speech_source, seed); the interval is a seeded cluster bootstrap "
              f"({N_BOOT} replicates) over them; non-finite values are left out of the means."]
    md = out / "tune_report.md"
    md.write_text("\n".join(lines) + "\n", encoding="utf-8")
    path_csv = out / "tune_report.csv"
    with path_csv.open("w", newline="", encoding="utf-8") as f:
        fields = ["metric", "dev", "test", "optimism", "ci_lo", "ci_hi", "dev_rows", "test_rows", "dev_units", "test_units"]
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(table)
    return md, path_csv
