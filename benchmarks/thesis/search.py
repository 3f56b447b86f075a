"""Search the readings of the source thesis for the one that reproduces its tables 7.1-7.9.

``scenesim thesis search [--data-dir DIR] [--alias babble=cafe ...] [--out DIR]`` (the same as
``python -m benchmarks.thesis.search``); ``scenesim thesis evaluate [--split test]`` (or ``--evaluate``)
scores the preset's reading :data:`BEST` on one data set without a search.  The code is in
:mod:`benchmarks.thesis.readings` (readings, cells, stages), :mod:`benchmarks.thesis.measure` (output
SNR), :mod:`benchmarks.thesis.protocol` (held-out error, identifiability) and
:mod:`benchmarks.thesis.command` (the command line).

A *reading* is one value for every unknown the thesis' text leaves open (its equations were
lost in extraction; :mod:`scenesim.scene.thesis_farfield` for the simulation):

==============  ================================================================================
unknown         values searched (why)
==============  ================================================================================
azimuth_from    ``axis`` / ``broadside``: theta is never defined in the surviving text
fd_taps         odd sinc lengths 9..65: "a truncated finite length sinc" (2.5.1), no length given
fd_window       ``rect`` (plain truncation, the text) / ``hann`` (its section title says "windowed")
adapt           NLMS always adapting (``mu`` 0.05 or 0.005, "free"/"slow") or frozen while the
                frontal talker dominates (``gated``): the thesis says only "NLMS", block-averaged
beta_max        1 (Elko: null anywhere in the rear half plane), 0.5, 0.2 (null kept within
                110 / 132 deg of the rear endfire: the thesis gives no limit)
eq_fc_hz        corner of the "first-order low-pass" at the output, 50..600 Hz (not given)
eq_hf           ``0``: that low-pass alone / ``None``: plus our high-frequency correction
ss_alpha        SS smoothing 0.9 / 0.95 (section 5.2.6 gives the range; 6.2 lost the value)
osub            SS over-subtraction: ``berouti`` (osub = 4 - 0.15 SNR in [1, 4.75], algorithms.md 6)
                or fixed at 1 or 2 (``fixed1``, ``fixed2``): the rule is lost from the text
subf            SS spectral floor 0.01 / 0.02 / 0.05 (lost)
subtract        SS ``magnitude`` / ``power`` subtraction (lost; :mod:`enhancers.single.ss`)
measure         output SNR by ``replay`` / ``y-s`` / ``hagerman`` (:mod:`benchmarks.thesis.measure`):
                eq. 7.1 names the powers, not how speech and noise were told apart at the output
==============  ================================================================================

Fixed by the text: 16 kHz, d = 2.14 cm with exactly one sample of internal delay, far-field
sources at 45 and 270 deg, the truncated sinc about the array midpoint, SNR at the mic by
eqs. 6.1/7.1 (whole-signal mean squares), SS with 16 ms Hamming, 50 % overlap, D = 200 frames,
omin = 0.99.  Not searched: the noise level (eq. 7.1 sets it at the mic, so any source level
is scaled away) and its type (the data set is the axis: built-in or ``--data-dir``).

Score of a reading over the 54 cells of tables 7.1-7.9: mean ``|ΔSNR-I|`` (dB) and mean
``|Δ raw PESQ out|``; and the EB trend error, mean over noises of
``|(SNR-I(25 dB) - SNR-I(0 dB)) - thesis'|`` (the thesis' EB is flat within 1.2 dB).
Stages: (1) a coarse factorial grid on the 18 EB cells by SNR-I only (fast: the beta
sequence does not depend on the output filter, so every ``eq`` variant reuses one run);
(2) the best kept reading of each (convention, adaptation, beta limit) family, ``--top`` of them,
on the 18 EB cells with raw PESQ, ranked by :func:`combined` (each mean distance over its target);
(3) refine ``fd_taps`` and ``eq_fc_hz`` around the leader by SNR-I; (4) the SS stage: that EB reading
with every combination of the SS unknowns (:data:`SS_GRID`, 36) on all 54 cells by SNR-I under each of
the three measurements (108 readings; one run of ``s + n`` and one of ``s - n`` per cell serve all
three), the best :data:`SS_TOP` again with PESQ, ranked by :func:`combined`.  The EB unknowns are
chosen under ``replay`` (stages 1-3) and the measurement after them.  Readings whose EB trend error exceeds
:data:`TREND_LIMIT_DB` or whose EB mean ``|ΔSNR-I|`` exceeds :data:`EB_LIMIT_DB` are excluded.
Scenes are rendered once per (model, noise) and reused.

**Protocol** (:mod:`benchmarks.thesis.protocol`).  The search above runs on ``dev`` material (the
*fit*), and is scored on ``test`` material.  Held-out error: the search run on dev and one family of
tables (babble, or factory + wind) chooses a reading that is scored on test and on the other family
only.  Identifiability: the best 24 EB readings (stages 1 and 3, by the 18 EB cells' SNR-I) and the best
12 SS-stage readings (by :func:`combined` over 54 cells with PESQ) on 5 dev seeds; a paired bootstrap
(1000 resamples of the seeds) keeps the readings whose 95 % interval of score minus the best's holds 0.

**Measured** (``scenesim thesis search --out DIR``: 8 s cells, full grid, seed 0 to choose, seeds 0-4
for the bootstrap; built-in data, and ``--data-dir ../shared/data --alias babble=cafe
factory=machinery``; 7.6 and 8.2 min CPU).  Mean ``|ΔSNR-I|`` (dB) / mean ``|Δ raw PESQ|``:

==========  =====================  ==================  ==================
data        chosen on -> scored on  in-sample (dev)     held-out (test)
==========  =====================  ==================  ==================
built-in    babble -> factory+wind  0.99 / 0.176        4.03 / 0.292
built-in    factory+wind -> babble  2.88 / 0.362        1.31 / 0.230
built-in    all -> all              2.37 / 0.316        2.34 / 0.255
real        babble -> factory+wind  0.93 / 0.169        6.24 / 0.385
real        factory+wind -> babble  2.18 / 0.368        1.30 / 0.382
real        all -> all              1.73 / 0.342        2.05 / 0.425
==========  =====================  ==================  ==================

A reading chosen on babble alone misses factory and wind by 4-6 dB: the in-sample error of one family
says little about the other.  :data:`BEST` scores 2.72 / 0.249 (built-in) and 2.01 / 0.399 (real) on
test material.  In :func:`combined` on test material, the built-in fit is 0.16 better than it on
built-in data and 0.72 worse on real recordings; the real-data fit 0.06 better on built-in and 0.15
worse on real: no reading is better on both, so :data:`BEST` is kept.  (``all -> all``: the same
tables, only the material held out.)
Identifiability (EB block by SNR-I only): 3 and 2 of 24 readings in the set; they agree on
broadside angles, a 33-tap rectangular sinc, gated NLMS, a 150 Hz low-pass -- PESQ, not SNR-I, is what
moves the fit to always-adapting NLMS with beta <= 0.2 -- and leave beta_max (built-in: the gate keeps
beta below every limit) or the HF correction open.  SS block: 3 of 12 in each set; alpha 0.95 and
magnitude subtraction agreed on both; the floor (real) or the over-subtraction rule and replay against
Hagerman (built-in) are not identified.  ``y - s`` is excluded on both: it counts the differential
response's colouration of the talker as noise (EB cells 17.7-20.9 dB off, trend off by 23 dB), although
it alone makes SS lower the SNR after the EB at 25 dB (factory: -1.2 dB built-in, -3.2 dB real; thesis
-3.9 dB; replay +3.1 to +3.9 dB).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from benchmarks.thesis.readings import (  # the search's names, where they have always been importable
    ADAPT,
    BEST,
    COARSE,
    EB_LIMIT_DB,
    OSUB,
    SMALL,
    SS_GRID,
    SS_TOP,
    THESIS_SNRS,
    TREND_LIMIT_DB,
    Cells,
    Reading,
    Score,
    cell_runs,
    coarse_grid,
    combined,
    eb_snr_i,
    evaluate_lines,
    excluded_because,
    exclusion_summary,
    full_cells,
    pick,
    refine,
    report_lines,
    residual_table,
    run_search,
    score_cells,
    sensitivity,
    ss_stage,
)

__all__ = ["THESIS_SNRS", "TREND_LIMIT_DB", "EB_LIMIT_DB", "ADAPT", "COARSE", "SMALL", "OSUB", "SS_GRID", "SS_TOP", "Reading", "Score", "score_cells", "Cells", "eb_snr_i", "cell_runs", "pick", "full_cells", "BEST", "coarse_grid", "refine", "excluded_because", "sensitivity", "combined", "run_search", "ss_stage", "residual_table", "exclusion_summary", "report_lines", "evaluate_lines", "main"]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m benchmarks.thesis.search``: ``scenesim thesis search`` (``--evaluate``: ``thesis evaluate``)."""
    from benchmarks.thesis.command import standalone

    return standalone(argv)


if __name__ == "__main__":
    sys.exit(main())
