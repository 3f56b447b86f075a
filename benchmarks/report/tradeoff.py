"""The ideal-vs-robust trade-off in one table (issue 16 part 5).

``eb`` is the thesis' adaptive differential beamformer; ``eb-robust`` adds the mic
self-calibration, a noise-aware equaliser and a DAS fallback so that it survives real
microphones.  The robustness has a price where the mics are ideal: :func:`tradeoff_section`
shows both systems with ideal mics (``ideal_sensors == 1``: the thesis' conditions) and with
real ones (tolerances drawn per seed, or a nominal mismatch), per noise: mean SNR-I, raw
PESQ (P.862, narrow band) and STOI.  Each seed's mean over its conditions first, then the
spread over seeds only (never over input SNRs), shown as the report shows every statistic
(:func:`benchmarks.report.tables.stat_cell`: the value for one seed, min … max below five,
else a 95 % t-interval); ``n`` is the number of seeds.  Shown only when both systems ran.

Rows with a reverberation-metric target are left out (they have their own section).  Rows
are :func:`benchmarks.report.tables.normalise_rows` rows with ``status == 'ok'``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from benchmarks.report.tables import (
    SMALL_N_TEXT,
    aggregate_over_seeds,
    markdown_table,
    stat_cell,
    write_csv,
)

__all__ = ["SYSTEMS", "tradeoff_records", "tradeoff_section"]

SYSTEMS = ("eb", "eb-robust")
FIELDS = ("snr_i_db", "pesq_nb_raw_out", "stoi_out")
KEYS = ("enhancer", "mics", "noise")


def tradeoff_records(ok: Sequence[dict]) -> list[dict]:
    """Per (system, mics, noise): the means of :data:`FIELDS` over seeds (``n`` = seeds).

    Two input SNRs of one seed count once: the spread is over seeds only.

    >>> rows = [{"enhancer": "eb", "ideal_sensors": i, "noise": "babble", "seed": seed,
    ...          "snr_i_db": 10.0 + 20 * i + snr / 5, "pesq_nb_raw_out": 2.0, "stoi_out": 0.8}
    ...         for i in (0, 1) for seed in (0, 1) for snr in (0.0, 10.0)]
    >>> [(r["mics"], r["n"], r["snr_i_db"]) for r in tradeoff_records(rows)]
    [('ideal', 2, 31.0), ('real', 2, 11.0)]
    """
    rows = [
        {**r, "mics": "ideal" if int(r["ideal_sensors"]) else "real"}
        for r in ok
        if r.get("enhancer") in SYSTEMS and r.get("ideal_sensors") is not None and not r.get("metric_target")
    ]
    return aggregate_over_seeds(rows, KEYS, FIELDS)


def tradeoff_section(ok: Sequence[dict], report_dir: Path) -> tuple[list[str], list[Path]]:
    """``(markdown lines, [tradeoff.csv])``; nothing without ``eb`` / ``eb-robust`` rows."""
    recs = tradeoff_records(ok)
    if {r["enhancer"] for r in recs} != set(SYSTEMS):
        return [], []  # the trade-off needs both systems
    body = [[r["enhancer"], r["mics"], r["noise"], r["n"], *(stat_cell(r, f) for f in FIELDS)] for r in recs]
    path = write_csv(Path(report_dir) / "tradeoff.csv", recs, [*KEYS, "n", *FIELDS, *(f + "_ci95" for f in FIELDS)])
    lines = [
        "## Ideal vs robust: eb and eb-robust with ideal and with real microphones",
        "",
        "What robustness costs where the mics are ideal and what it buys where they are not "
        f"(each seed's mean over its conditions, then over seeds; {SMALL_N_TEXT} PESQ is raw P.862).",
        "",
        markdown_table(["system", "mics", "noise", "n seeds", "SNR-I (dB)", "PESQ raw", "STOI"], body),
        "",
    ]
    return lines, [path]
