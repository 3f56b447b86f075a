"""Report text of the thesis reproduction (issue 17): the ``thesis-repro`` section and the finding
every report's thesis section states.

The finding (measured by ``python -m benchmarks.thesis_search``, README "Reproducing the thesis"):
the thesis' EB numbers are not explained by ideal sensors -- the thesis had the same
idealisation -- but by its own simulation.  Read with its angles measured from broadside (its
270 deg noise then sits at the rear endfire, where the forward cardioid nulls it) and each mic
made by a plain truncated sinc about the array midpoint, the two mics are not exact shifted
replicas of one plane wave: the truncated tails leave a broadband error that the differential
pair cannot cancel and its low-pass output raises at low frequencies.  That residual, not the
beta the NLMS finds, sets the EB's SNR-I, which is therefore flat across input SNR and depends
on the noise spectrum, as in tables 7.1-7.3.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from benchmarks import thesis_reference as T
from benchmarks.thesis_search import score_cells

#: The reading of the ``thesis-repro`` preset, in words (the preset's TOML has the values).
READING = (
    "angles from broadside (270° = rear endfire, 45° unchanged); each mic by a 33-tap rectangular "
    "(plain truncated) sinc about the array midpoint; EB with a one-sample internal delay, NLMS beta "
    "(block 1 ms, mu 0.05) in [0, 1] frozen while the frontal talker dominates, first-order low-pass "
    "output with a 150 Hz corner; SS with 16 ms Hamming, 50 % overlap, D = 200 frames, omin = 0.99, "
    "alpha 0.9; SNR by eqs. 6.1/7.1 at the front mic"
)

#: What the search excluded and why (built-in data, 768 coarse readings; README has the command).
EXCLUDED = (
    "Every reading with angles from the axis (270° = broadside) is either far above the tables (both mics "
    "receive the noise bit-identically, the dipole nulls it: 28-42 dB) or, with beta capped at 0.8, "
    "orders the noises wrongly; an always-adapting NLMS with the noise at the rear endfire follows the "
    "talker (beta -> 1 at high input SNR) and loses 8-12 dB of SNR-I from 0 to 25 dB, where the thesis "
    "loses 1.2 dB; a Hann-windowed sinc leaves no residual (null 29-42 dB). Only plain truncation, a "
    "frozen-during-speech beta and the broadside convention stay within the trend and level limits."
)


def is_repro_row(row: dict) -> bool:
    """True for rows simulated by the thesis' own model (``far_field_method = "thesis"``)."""
    return T.condition_params(row).get("far_field_method") == "thesis"


def reading_the_comparison() -> list[str]:
    """The paragraph every report's thesis section gives on why ideal-sensor numbers exceed the tables."""
    return [
        "**Reading the comparison.** Ideal sensors do not explain the gap: the thesis had the same "
        "idealisation. With exact plane waves the 270° noise reaches both mics bit-identically and a "
        "dipole cancels it, so this preset's EB and EB-SS are an upper bound of the method. The thesis' "
        "tables are reproduced by its *own* simulation (preset `thesis-repro`; reading: " + READING + "): "
        "its truncated-sinc mic signals are not exact replicas of one plane wave, and that residual, not "
        "the microphones, limits its EB to 13-20 dB. SS sees one mic and is unaffected. PESQ depends on "
        "the speech material: compare PESQ with the thesis on real speech (`--data-dir`).",
        "",
    ]


def _cells(rows: Sequence[dict]) -> dict[tuple, tuple]:
    """Mean over seeds per (thesis system, noise, input SNR): (SNR-I, raw PESQ out or None)."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        system = T.thesis_system(r["enhancer"])
        if system is not None and r.get("snr_i_db") is not None:
            groups.setdefault((system, r["noise"], float(r["snr_in_db"])), []).append(r)
    out = {}
    for key, rs in groups.items():
        pesq = [r["pesq_nb_raw_out"] for r in rs if r.get("pesq_nb_raw_out") is not None]
        out[key] = (sum(r["snr_i_db"] for r in rs) / len(rs), sum(pesq) / len(pesq) if pesq else None)
    return out


def _fmt(v, digits=2) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def repro_section(ok_rows: Sequence[dict]) -> list[str]:
    """The ``thesis-repro`` section: the reading, cell-by-cell comparison, residuals, exclusions."""
    rows = [r for r in ok_rows if is_repro_row(r) and T.is_thesis_condition(r)]
    if not rows:
        return []
    cells = _cells(rows)
    score = score_cells(cells)
    verdict = ("within" if score.snr_i <= 2.0 and (math.isnan(score.pesq) or score.pesq <= 0.2)
               else "outside")
    lines = [
        "## Thesis reproduction (its own simulation)",
        "",
        f"Reading: {READING}.",
        "",
        f"Over the {score.n_snr} cells compared: mean |ΔSNR-I| **{_fmt(score.snr_i)} dB**, mean |Δ raw PESQ out| "
        f"**{_fmt(score.pesq, 3)}** ({score.n_pesq} cells), EB trend error {_fmt(score.trend)} dB "
        f"(SNR-I at 25 dB minus at 0 dB, ours vs the thesis'): {verdict} the target of 2 dB / 0.2. "
        "Δ = ours − thesis; PESQ is raw P.862 (the thesis' scale).",
        "",
        "| table | system | noise | SNR in | SNR-I | thesis | Δ | PESQ out | thesis | Δ |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for ref in T.load_thesis_tables():
        ours = cells.get((ref.system, ref.noise, float(ref.snr_in_db)))
        if ours is None:
            continue
        dp = None if ours[1] is None else ours[1] - ref.pesq_out
        lines.append(f"| {ref.table} | {ref.system} | {ref.noise} | {ref.snr_in_db:g} | {_fmt(ours[0])} | "
                     f"{_fmt(ref.snr_i_db)} | {_fmt(ours[0] - ref.snr_i_db)} | {_fmt(ours[1], 3)} | "
                     f"{_fmt(ref.pesq_out, 3)} | {_fmt(dp, 3)} |")
    return [*lines, "", f"**Excluded by the search.** {EXCLUDED}", ""]
