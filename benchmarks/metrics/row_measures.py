"""The distortion, G.160 and attribution columns of a results row (issue 16), from signals evaluate has.

Three groups, each computed by one function so a failure in one leaves the others:

* :func:`distortion_columns` -- ``speech_jitter_db`` and ``hagerman_leak_db``
  (:mod:`benchmarks.metrics.distortion`) from the two Hagerman runs' replayed operations: ``W1`` is
  the Result of ``s + n`` (the row's own run, whose replays the row already has), ``W2`` that
  of ``s - n`` (the Hagerman run); each is replayed on the speech and on the noise (``+n``).
  Replayable systems only; no extra enhancer run.
* :func:`g160_columns` -- ``g160_snri_db``, ``g160_tnlr_db``, ``g160_dsn_db``
  (:mod:`benchmarks.metrics.g160`): the recommendation's estimate from mixture and output for every
  system, with P.56 activity; ``g160_*_exact_db`` from the replayed parts where replayable.
* :func:`attribution_columns` -- ``snr_i_spectral_db``, ``snr_i_spatial_db`` and the per-octave
  SNR-I as JSON in ``snr_i_octave_json`` (:mod:`benchmarks.metrics.attribution`).
* :func:`split_columns` -- ``snr_i_fixed_spectral_db`` (1/3-octave rule, every system) and
  ``snr_i_fixed_spatial_db``, ``snr_i_time_varying_db`` from the output replayed on each input
  channel alone (:mod:`benchmarks.metrics.attribution_split`).  For black boxes
  (``snr_method`` = ``'phase-inversion'``) the last two stay empty: no channel's own response
  can be measured.

Every signal handed in is 1-D, latency-aligned and as long as the row's aligned reference.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from benchmarks.metrics import speech as M
from benchmarks.metrics.attribution import octave_snr_i, snr_i_spectral_db
from benchmarks.metrics.attribution_split import SPLIT_COLUMNS, fixed_spectral_snr_i_db, snr_i_split
from benchmarks.metrics.distortion import hagerman_leak_db, speech_jitter_db
from benchmarks.metrics.g160 import (
    G160_COLUMNS,
    G160_EXACT_COLUMNS,
    G160Undefined,
    g160_measures,
    g160_measures_blackbox,
)

__all__ = ["MEASURE_COLUMNS", "attribution_columns", "distortion_columns", "g160_columns", "split_columns"]

#: Result columns added by this module (SQL types for the store).
MEASURE_COLUMNS: dict[str, str] = {
    "speech_jitter_db": "REAL",
    "hagerman_leak_db": "REAL",
    "g160_snri_db": "REAL",
    "g160_tnlr_db": "REAL",
    "g160_dsn_db": "REAL",
    "g160_snri_exact_db": "REAL",
    "g160_tnlr_exact_db": "REAL",
    "g160_dsn_exact_db": "REAL",
    "snr_i_spectral_db": "REAL",
    "snr_i_spatial_db": "REAL",
    "snr_i_octave_json": "TEXT",
    **dict.fromkeys(SPLIT_COLUMNS, "REAL"),
}


def distortion_columns(result2, s, n, s_out1, n_out1, *, latency: int, n_ref: int) -> dict[str, Any]:
    """``speech_jitter_db`` and ``hagerman_leak_db`` of the first output channel.

    ``result2``: the Result of ``s - n`` (W2); ``s, n`` the enhancer's input speech and noise
    ``(channels, samples)``; ``s_out1, n_out1``: W1 (the Result of ``s + n``) replayed on them,
    ``(n_out, samples)``, already computed by the caller; ``n_ref`` the reference length the
    output is aligned to.
    """
    def aligned(v):
        return M.align(np.asarray(v, dtype=np.float64)[0], np.empty(n_ref), latency_samples=latency)[0]

    w1s, w2s = aligned(s_out1), aligned(result2.replay(s))
    w1n, w2n = aligned(n_out1), aligned(result2.replay(n))
    return {"speech_jitter_db": speech_jitter_db(w1s, w2s), "hagerman_leak_db": hagerman_leak_db(w1s, w2s, w1n, w2n)}


def g160_columns(clean, fs: int, *, mixture, output, parts=None) -> dict[str, float | None]:
    """G.160 measures on one footing: :data:`G160_COLUMNS` the recommendation's estimate from
    ``mixture`` and ``output`` for every system; with ``parts = (s_in, n_in, s_out, n_out)``
    (a replayable system) also the exact values, :data:`G160_EXACT_COLUMNS` (else None).

    Empty (None) where the recommendation's measures are undefined for the signal (too few
    speech or noise-only frames, e.g. speech without pauses): not an error of the row.
    """
    out: dict[str, float | None] = dict.fromkeys((*G160_COLUMNS, *G160_EXACT_COLUMNS))
    try:
        out.update(g160_measures_blackbox(clean, mixture, output, fs))
    except G160Undefined:
        pass
    if parts is not None:
        try:
            exact = g160_measures(clean, *parts, fs)
        except G160Undefined:
            return out
        out.update({e: exact[k] for k, e in zip(G160_COLUMNS, G160_EXACT_COLUMNS)})
    return out


def attribution_columns(s_in, n_in, s_out, n_out, fs: int, *, snr_i_db, self_noise=None) -> dict[str, Any]:
    """``snr_i_spectral_db``, ``snr_i_spatial_db`` (``snr_i_db`` minus it) and ``snr_i_octave_json``."""
    spectral = snr_i_spectral_db(s_in, n_in, s_out, fs)
    octave = octave_snr_i(s_in, n_in, s_out, n_out, fs, self_noise=self_noise)
    return {
        "snr_i_spectral_db": spectral,
        "snr_i_spatial_db": None if snr_i_db is None else float(snr_i_db) - spectral,
        "snr_i_octave_json": json.dumps(octave, separators=(",", ":")),
    }


def split_columns(result, s, n, aligned, fs: int, *, latency: int, snr_i_db) -> dict[str, Any]:
    """:data:`~benchmarks.metrics.attribution_split.SPLIT_COLUMNS` of a row.

    ``result``: the row's Result, None for a black box (then only ``snr_i_fixed_spectral_db``,
    from the estimated parts ``aligned``); ``s, n``: speech and noise ``(channels, samples)`` as the
    enhancer took them; ``aligned = (s_al, n_al)``: the first output channel's replayed
    speech and noise, latency-aligned, length ``m``.  Channel ``c < C - 1`` is replayed alone;
    the last channel's part is the rest of ``s_al`` (replay is linear), so ``C - 1`` extra
    replays of each component.
    """
    s_al, n_al = aligned
    m = s_al.size
    if result is None or snr_i_db is None:
        return {SPLIT_COLUMNS[0]: fixed_spectral_snr_i_db(s[0, :m], n[0, :m], s_al, n_al, fs)}
    s_parts, n_parts = np.zeros((s.shape[0], m)), np.zeros((s.shape[0], m))
    for c in range(s.shape[0] - 1):
        for comp, parts in ((s, s_parts), (n, n_parts)):
            alone = np.zeros_like(comp)
            alone[c] = comp[c]
            parts[c] = np.asarray(result.replay(alone), dtype=np.float64)[0, latency : latency + m]
    s_parts[-1], n_parts[-1] = s_al - s_parts[:-1].sum(axis=0), n_al - n_parts[:-1].sum(axis=0)
    return snr_i_split(s[:, :m], n[:, :m], s_parts, n_parts, fs, snr_i_db=snr_i_db)
