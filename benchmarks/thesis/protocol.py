"""The fitted reading judged honestly: its held-out error and which of its unknowns the data identify.

**Held-out error** (:func:`held_out`).  The reading is chosen by :func:`~benchmarks.thesis.search.run_search`
on ``dev`` material and on one family of tables, and scored on ``test`` material and on the other
family: babble -> factory + wind, and factory + wind -> babble (:data:`DIRECTIONS`).  The in-sample
number is the chosen reading's score on what chose it (dev, its own family); the held-out number is
its score on the other family's test cells only -- the cells of the family it was chosen on are
dropped before scoring, whatever the evaluator returns.

**Identifiability** (:func:`bootstrap_scores`, :func:`identifiable_set`).  The search's top readings
are evaluated on several seeds (each seed draws another utterance and other noise segments).  A
seeded paired bootstrap resamples the seeds with replacement (``n_boot`` times, the same resample for
every reading), averages each cell over the resampled seeds as the report does, and scores every
reading on it.  **Rule:** a reading belongs to the set when the 95 % percentile interval of its score
minus the best reading's score (paired over the resamples) contains 0; the best is the reading of the
lowest score on all seeds.  An unknown is identified when every reading of the set has one value.

>>> full = {"a": 1.0, "b": 1.2, "c": 3.0}
>>> boots = {"a": np.array([1.0, 0.9, 1.1]), "b": np.array([0.8, 1.2, 1.4]), "c": np.array([3.0, 2.9, 3.1])}
>>> [(r["reading"], r["in_set"]) for r in identifiable_set(full, boots)]
[('a', True), ('b', True), ('c', False)]
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from benchmarks.thesis.readings import (
    BEST,
    COARSE,
    SS_GRID,
    Cells,
    Reading,
    Score,
    cell_runs,
    combined,
    eb_snr_i,
    excluded_because,
    full_cells,
    pick,
    run_search,
    score_cells,
)

DIRECTIONS = ((("babble",), ("factory", "wind")), (("factory", "wind"), ("babble",)))
"""(chosen on, scored on): the two families of tables, each way."""
LEVEL = 0.95
"""Coverage of the paired bootstrap interval of the identifiability rule."""
RESULTS_NAME = "thesis_search.json"
"""The file ``scenesim thesis search --out DIR`` writes (the report reads it)."""


def score_dict(score: Score) -> dict:
    """A :class:`Score` as JSON-able numbers (NaN as None)."""
    return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in dataclasses.asdict(score).items()}


def family_score(cells: Mapping[tuple, tuple], family: Sequence[str]) -> Score:
    """The score of the cells whose noise is in ``family`` (the others are dropped first)."""
    return score_cells({k: v for k, v in cells.items() if k[1] in set(family)})


def held_out(choose: Callable[[tuple], tuple[Reading, Score]],
             evaluate: Callable[[Reading, tuple], Mapping[tuple, tuple]],
             directions: Sequence[tuple] = DIRECTIONS) -> list[dict]:
    """In-sample against held-out error, one entry per direction.

    ``choose(family)`` -> ``(reading, in-sample score)``: the search on dev material restricted to the
    family's tables; ``evaluate(reading, family)`` -> cells on test material.  Only the scored
    family's cells enter the held-out score.
    """
    out = []
    for chosen_on, scored_on in directions:
        reading, in_sample = choose(tuple(chosen_on))
        held = family_score(evaluate(reading, tuple(scored_on)), scored_on)
        out.append({"chosen_on": list(chosen_on), "scored_on": list(scored_on),
                    "reading": dataclasses.asdict(reading), "label": reading.label(),
                    "in_sample": score_dict(in_sample), "held_out": score_dict(held)})
    return out


# -- identifiability -----------------------------------------------------------------------


def _mean_cells(per_seed: Sequence[Mapping[tuple, tuple]], idx: Sequence[int]) -> dict[tuple, tuple]:
    """Each cell's mean over the seeds ``idx`` (a resample): SNR-I, and PESQ where every seed has one."""
    out = {}
    for key in per_seed[0]:
        snr = [per_seed[i][key][0] for i in idx]
        pesq = [per_seed[i][key][1] for i in idx]
        out[key] = (float(np.mean(snr)), None if any(p is None for p in pesq) else float(np.mean(pesq)))
    return out


def bootstrap_scores(per_seed: Mapping[object, Sequence[Mapping[tuple, tuple]]],
                     score: Callable[[Mapping[tuple, tuple]], float], *, n_boot: int = 1000,
                     seed: int = 0) -> tuple[dict, dict]:
    """``(full, boots)``: each reading's score on all seeds, and on ``n_boot`` paired resamples of the
    seeds (``boots[r]``: ``(n_boot,)``, resample ``b`` the same seeds for every reading)."""
    n_seeds = len(next(iter(per_seed.values())))
    draws = np.random.default_rng(seed).integers(0, n_seeds, size=(n_boot, n_seeds))
    full = {r: score(_mean_cells(cells, range(n_seeds))) for r, cells in per_seed.items()}
    boots = {r: np.array([score(_mean_cells(cells, d)) for d in draws]) for r, cells in per_seed.items()}
    return full, boots


def identifiable_set(full: Mapping[object, float], boots: Mapping[object, np.ndarray],
                     level: float = LEVEL) -> list[dict]:
    """Rows by score: ``reading``, ``score``, ``diff_lo`` / ``diff_hi`` (the paired percentile
    interval of score minus the best's) and ``in_set`` (the interval contains 0)."""
    best = min(full, key=full.get)
    q = (100 * (1 - level) / 2, 100 * (1 + level) / 2)
    rows = []
    for r in sorted(full, key=full.get):
        lo, hi = (float(v) for v in np.percentile(boots[r] - boots[best], q))
        rows.append({"reading": r, "score": float(full[r]), "diff_lo": lo, "diff_hi": hi,
                     "in_set": bool(lo <= 0.0 <= hi)})
    return rows


def agreement(rows: Sequence[dict], unknowns: Sequence[str]) -> dict[str, list]:
    """Per unknown, the values the readings of the set take (one value: the set agrees on it)."""
    members = [r["reading"] for r in rows if r["in_set"]]
    return {u: sorted({getattr(m, u) for m in members}, key=str) for u in unknowns}


def _ident_block(per_seed: Mapping[Reading, list], score, unknowns, *, n_boot: int, seed: int, what: str) -> dict:
    full, boots = bootstrap_scores(per_seed, score, n_boot=n_boot, seed=seed)
    rows = identifiable_set(full, boots)
    agree = agreement(rows, unknowns)
    return {"score": what, "rows": [{**r, "reading": dataclasses.asdict(r["reading"]), "label": r["reading"].label()}
                                    for r in rows],
            "agreement": {u: [str(v) for v in vals] for u, vals in agree.items()},
            "n_set": sum(r["in_set"] for r in rows), "n_readings": len(rows)}


def identifiability(seed_cells: Sequence[Cells], fit: Mapping, *, top_eb: int = 24, top_ss: int = 12,
                    with_pesq: bool = True, n_boot: int = 1000, boot_seed: int = 0, log=print) -> dict:
    """The two blocks of unknowns on the seeds of ``seed_cells`` (one :class:`Cells` per seed).

    EB: the ``top_eb`` best kept readings of the coarse and refining stages, on the 18 EB cells by
    mean |ΔSNR-I| (one shared EB run per beta group and seed).  SS: the ``top_ss`` best kept readings
    of the SS stage, on all 54 cells by :func:`combined` (PESQ once per SS setting and seed).
    """
    stage = {**fit["coarse"], **fit["fine"]}
    eb_top = sorted((r for r, s in stage.items() if not excluded_because(s)), key=lambda r: stage[r].snr_i)[:top_eb]
    eb_cells = {r: [] for r in eb_top}
    for cells in seed_cells:
        got = eb_snr_i(cells, eb_top)
        for r in eb_top:
            eb_cells[r].append(got[r])
    log(f"identifiability: {len(eb_top)} EB readings x {len(seed_cells)} seeds")
    ss = fit["ss"]
    ss_top = sorted((r for r, s in ss.items() if not excluded_because(s)), key=lambda r: ss[r].snr_i)[:top_ss]
    ss_cells = {r: [] for r in ss_top}
    for cells in seed_cells:
        runs = {}
        for r in ss_top:
            key = dataclasses.replace(r, measure="replay")
            if key not in runs:
                runs[key] = cell_runs(cells, key, with_pesq=with_pesq)
            ss_cells[r].append(pick(runs[key], r.measure))
    log(f"identifiability: {len(ss_top)} SS readings x {len(seed_cells)} seeds")
    seeds = dict(n_boot=n_boot, seed=boot_seed)
    return {
        "rule": f"paired bootstrap over seeds ({n_boot} resamples, seed {boot_seed}): a reading is in the set "
                f"when the {100 * LEVEL:g} % interval of its score minus the best's contains 0",
        "eb": _ident_block(eb_cells, lambda c: score_cells(c).snr_i, list(COARSE), **seeds,
                           what="mean |dSNR-I| over the 18 EB cells (dB)"),
        "ss": _ident_block(ss_cells, lambda c: combined(score_cells(c)), [*SS_GRID, "measure"], **seeds,
                           what="combined: mean |dSNR-I| / 2 dB + mean |dPESQ| / 0.2 over the 54 cells"),
    }


# -- the whole protocol --------------------------------------------------------------------


def _choose(cells: Cells, search: Mapping) -> Callable[[tuple], tuple[Reading, Score]]:
    def choose(family: tuple) -> tuple[Reading, Score]:
        res = run_search(cells.subset(family), **search)
        return res["best"], res["finalists"][0][1]

    return choose


def run_protocol(data_dir=None, *, duration_s: float = 8.0, seed: int = 0, n_seeds: int = 5,
                 aliases: Mapping[str, str] | None = None, with_pesq: bool = True, search: Mapping | None = None,
                 top_eb: int = 24, top_ss: int = 12, n_boot: int = 1000, log=print, keep_search: bool = False) -> dict:
    """Search on dev, held-out error both ways on test, identifiability on ``n_seeds`` dev seeds.

    ``search``: keyword arguments of :func:`run_search` (grid, top, ...).  Returns the JSON-able
    results :data:`RESULTS_NAME` holds (``keep_search``: plus the dev search's own result as ``"_search"``).
    """
    t0 = time.perf_counter()
    search = {"with_pesq": with_pesq, "log": log, **(search or {})}
    kw = {"duration_s": duration_s, "aliases": aliases}
    dev, test = Cells(data_dir, seed=seed, split="dev", **kw), Cells(data_dir, seed=seed, split="test", **kw)
    fit = run_search(dev, **search)
    best, in_sample, _ = fit["finalists"][0]
    on_test = {r.label(): score_dict(score_cells(full_cells(test, r, with_pesq=with_pesq))) for r in {best, BEST}}
    log(f"fit chosen on dev, scored on test ({time.perf_counter() - t0:.0f} s)")
    held = held_out(_choose(dev, search), lambda r, fam: full_cells(test.subset(fam), r, with_pesq=with_pesq))
    log(f"held-out: {len(held)} directions ({time.perf_counter() - t0:.0f} s)")
    seed_cells = [dev] + [Cells(data_dir, seed=seed + k, split="dev", **kw) for k in range(1, n_seeds)]
    ident = identifiability(seed_cells, fit, top_eb=top_eb, top_ss=top_ss, with_pesq=with_pesq, n_boot=n_boot,
                            log=log)
    out = {
        "data": str(data_dir) if data_dir else "built-in", "aliases": dict(aliases or {}), "duration_s": duration_s,
        "seed": seed, "ident_seeds": list(range(seed, seed + n_seeds)), "choose_split": "dev", "score_split": "test",
        "fit": {"reading": dataclasses.asdict(best), "label": best.label(), "in_sample": score_dict(in_sample),
                "test_all_tables": on_test[best.label()]},
        "preset": {"reading": dataclasses.asdict(BEST), "label": BEST.label(), "test_all_tables": on_test[BEST.label()]},
        "held_out": held, "identifiability": ident, "seconds": time.perf_counter() - t0,
    }
    if keep_search:
        out["_search"] = fit
    return out
