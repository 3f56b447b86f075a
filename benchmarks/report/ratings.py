"""The report's "Listening test" section: the ratings ``scenesim listen`` stored, against the metrics.

From the store's ``ratings`` table (one row per listener, condition, system and scale):

* **Screening** (:func:`screen_listeners`).  MUSHRA, ITU-R BS.1534-3 §4.1.2: a listener who rates
  the hidden reference below 90 in more than 15 % of their trials is excluded.  P.835 has no such
  rule; the analogue used here: a listener who rates the clean reference's background (BAK) worse
  than the unprocessed mixture's in more than 15 % of the conditions where they rated both is
  excluded.  Exclusion holds for that method's ratings only.
* **Means** (:func:`rating_means`): per method, scale, system and condition, the mean over the
  retained listeners with a 95 % Student-t interval, ``mean -/+ t_{0.975, n-1} s / sqrt(n)``.
* **Paired comparisons** (:func:`paired_comparisons`): for every pair of rated systems (the hidden
  reference and the anchor left out), the paired differences over (listener, condition) cells
  both were rated in; two-sided paired t-test, Holm's step-down correction over the pairs of one
  scale (Holm 1979), "separated" when ``p_holm < 0.05`` -- the rule the objective ranking uses.
* **Metric agreement** (:func:`metric_agreement`): over clips (condition, system), the mean rating
  of the retained listeners against each objective metric of the stored row: Pearson's r with the
  Fisher-z 95 % interval ``tanh(atanh r -/+ 1.96 / sqrt(n - 3))`` and Spearman's rho with the
  Fisher-z interval of Fieller, Hartley & Pearson (1957), ``tanh(atanh rho -/+ 1.96 sqrt(1.06 / (n - 3)))``
  (closed form: no bootstrap, so the report is deterministic).  PESQ-wb, ESTOI, SI-SDR and SNR-I
  against P.835 OVRL and the MUSHRA score; DNSMOS SIG/BAK/OVRL against the matching P.835 scale
  (and DNSMOS OVRL against MUSHRA), where the columns exist.

References: ITU-T P.835 (2003); ITU-R BS.1534-3 (2015); S. Holm, Scand. J. Statist. 6 (1979) 65-70;
E. C. Fieller, H. O. Hartley, E. S. Pearson, Biometrika 44 (1957) 470-481.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.report.listen_test import ANCHOR, MUSHRA_SCALE, P835_SCALES, REFERENCE
from benchmarks.report.tables import fmt, markdown_table, write_csv

#: BS.1534-3's post-screening: hidden reference below this score ...
MUSHRA_REFERENCE_MIN = 90.0
#: ... in more than this fraction of a listener's trials excludes them (the P.835 rule uses it too).
MAX_FAILED_FRACTION = 0.15
ALPHA = 0.05
Z_975 = 1.959963984540054
#: (metric column, label, scales it is compared with).
METRICS = (
    ("pesq_wb_out", "PESQ-wb", ("ovrl", MUSHRA_SCALE)),
    ("estoi_out", "ESTOI", ("ovrl", MUSHRA_SCALE)),
    ("si_sdr_out_db", "SI-SDR", ("ovrl", MUSHRA_SCALE)),
    ("snr_i_db", "SNR-I", ("ovrl", MUSHRA_SCALE)),
    ("dnsmos_sig", "DNSMOS SIG", ("sig",)),
    ("dnsmos_bak", "DNSMOS BAK", ("bak",)),
    ("dnsmos_ovrl", "DNSMOS OVRL", ("ovrl", MUSHRA_SCALE)),
)


def load_ratings(store_dir) -> list[dict[str, Any]]:
    """The ``ratings`` rows of the store in ``store_dir`` (none without a store or a ratings table)."""
    from benchmarks.store.sqlite import STORE_NAME, ResultStore

    if not (Path(store_dir) / STORE_NAME).is_file():
        return []
    with ResultStore.open(store_dir, readonly=True) as store:
        return store.ratings()


def _cells(ratings, method: str, scale: str) -> dict[tuple[str, str, str], float]:
    """``{(listener, condition_id, system): rating}`` of one method and scale."""
    return {(r["listener"], r["condition_id"], r["system"]): float(r["rating"])
            for r in ratings if r["method"] == method and r["scale"] == scale}  # fmt: skip


def screen_listeners(ratings: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per (method, listener): trials checked, trials failed, and whether they are excluded.

    >>> r = [{"listener": "a", "method": "mushra", "condition_id": c, "system": "reference",
    ...       "scale": "mushra", "rating": v} for c, v in (("c1", 100), ("c2", 80))]
    >>> [(s["listener"], s["failed"], s["checked"], s["excluded"]) for s in screen_listeners(r)]
    [('a', 1, 2, True)]
    """
    out = []
    for method, scale in (("mushra", MUSHRA_SCALE), ("p835", "bak")):
        cells = _cells(ratings, method, scale)
        for listener in sorted({k[0] for k in cells}):
            conds = sorted({c for (li, c, _) in cells if li == listener})
            if method == "mushra":
                refs = [cells[(listener, c, REFERENCE)] for c in conds if (listener, c, REFERENCE) in cells]
                failed = [v < MUSHRA_REFERENCE_MIN for v in refs]
            else:
                pairs = [(cells[(listener, c, REFERENCE)], cells[(listener, c, "mixture")]) for c in conds
                         if (listener, c, REFERENCE) in cells and (listener, c, "mixture") in cells]  # fmt: skip
                failed = [ref < mix for ref, mix in pairs]
            n_bad = sum(failed)
            out.append({"method": method, "listener": listener, "checked": len(failed), "failed": n_bad,
                        "excluded": bool(failed) and n_bad > MAX_FAILED_FRACTION * len(failed)})  # fmt: skip
    return out


def retained(ratings: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The ratings of listeners :func:`screen_listeners` keeps (per method)."""
    out_ = {(s["method"], s["listener"]) for s in screen_listeners(ratings) if s["excluded"]}
    return [r for r in ratings if (r["method"], r["listener"]) not in out_]


def t_interval(values: Sequence[float]) -> tuple[float, float | None, float | None]:
    """``(mean, low, high)``: the 95 % Student-t interval of the mean (None below two values).

    >>> t_interval([1.0, 2.0, 3.0])[0]
    2.0
    """
    from scipy.special import stdtrit

    x = np.asarray(values, dtype=float)
    if x.size < 2:
        return float(x.mean()), None, None
    half = float(stdtrit(x.size - 1, 0.975)) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return float(x.mean()), float(x.mean()) - half, float(x.mean()) + half


def rating_means(ratings: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per (method, scale, system, condition): ``n`` listeners, mean and its 95 % interval."""
    groups: dict[tuple, list[float]] = {}
    for r in ratings:
        groups.setdefault((r["method"], r["scale"], r["system"], r["condition_id"]), []).append(float(r["rating"]))
    out = []
    for (method, scale, system, cid), vals in sorted(groups.items()):
        mean, lo, hi = t_interval(vals)
        out.append({"method": method, "scale": scale, "system": system, "condition_id": cid,
                    "n": len(vals), "mean": mean, "ci_low": lo, "ci_high": hi})  # fmt: skip
    return out


def holm(p: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (Holm 1979), in the order given.

    >>> holm([0.01, 0.04, 0.03])
    [0.03, 0.06, 0.06]
    """
    order = sorted(range(len(p)), key=lambda i: p[i])
    adjusted, running = [0.0] * len(p), 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p) - rank) * p[i]))
        adjusted[i] = round(running, 12)
    return adjusted


def _paired_p(d: np.ndarray) -> float:
    """Two-sided p of the paired t-test on differences ``d`` (1 for no spread and zero mean)."""
    from scipy.special import stdtr

    sd = float(d.std(ddof=1))
    if sd == 0.0:
        return 1.0 if float(d.mean()) == 0.0 else 0.0
    t = float(d.mean()) / (sd / math.sqrt(d.size))
    return float(2.0 * stdtr(d.size - 1, -abs(t)))


def paired_comparisons(ratings: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per (method, scale) and pair of systems (hidden reference and anchor left out): mean
    difference ``b - a`` over shared (listener, condition) cells, its interval, p and Holm's p."""
    out = []
    for method, scales in (("p835", P835_SCALES), ("mushra", (MUSHRA_SCALE,))):
        for scale in scales:
            cells = _cells(ratings, method, scale)
            systems = sorted({s for (_, _, s) in cells} - {REFERENCE, ANCHOR})
            recs = []
            for a, b in combinations(systems, 2):
                keys = sorted({(li, c) for (li, c, s) in cells if s == a} & {(li, c) for (li, c, s) in cells if s == b})
                if len(keys) < 2:
                    continue
                d = np.array([cells[(*k, b)] - cells[(*k, a)] for k in keys])
                mean, lo, hi = t_interval(d)
                recs.append({"method": method, "scale": scale, "a": a, "b": b, "n": len(keys),
                             "mean_diff": mean, "ci_low": lo, "ci_high": hi, "p": _paired_p(d)})  # fmt: skip
            for rec, p in zip(recs, holm([r["p"] for r in recs])):
                rec["p_holm"], rec["separated"] = p, p < ALPHA
            out += recs
    return out


def fisher_interval(r: float, n: int, *, spearman: bool = False) -> tuple[float | None, float | None]:
    """95 % interval of a correlation ``r`` over ``n`` pairs by Fisher's z (see the module docstring).

    >>> [round(v, 4) for v in fisher_interval(0.5, 28)]
    [0.156, 0.7358]
    """
    if n < 4:
        return None, None
    if abs(r) >= 1.0:
        return float(r), float(r)
    half = Z_975 * math.sqrt((1.06 if spearman else 1.0) / (n - 3))
    z = math.atanh(r)
    return math.tanh(z - half), math.tanh(z + half)


def _clip_means(ratings, method: str, scale: str) -> dict[tuple[str, str], float]:
    groups: dict[tuple[str, str], list[float]] = {}
    for (_, cid, system), v in _cells(ratings, method, scale).items():
        groups.setdefault((cid, system), []).append(v)
    return {k: float(np.mean(v)) for k, v in groups.items()}


def metric_agreement(ratings: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per metric and scale (:data:`METRICS`): Pearson and Spearman over clips with intervals."""
    from scipy.stats import pearsonr, spearmanr

    by_clip = {(str(r["condition_id"]), str(r["enhancer"])): r for r in rows}
    out = []
    for column, label, scales in METRICS:
        for scale in scales:
            method = "mushra" if scale == MUSHRA_SCALE else "p835"
            pairs = [(float(by_clip[k][column]), v) for k, v in sorted(_clip_means(ratings, method, scale).items())
                     if k in by_clip and by_clip[k].get(column) is not None]  # fmt: skip
            if len(pairs) < 3:
                continue
            x, y = np.array(pairs).T
            constant = np.ptp(x) == 0 or np.ptp(y) == 0
            r = math.nan if constant else float(pearsonr(x, y).statistic)
            rho = math.nan if constant else float(spearmanr(x, y).statistic)
            rec = {"metric": column, "label": label, "method": method, "scale": scale, "n": len(pairs),
                   "pearson": r, "spearman": rho}  # fmt: skip
            rec["pearson_low"], rec["pearson_high"] = fisher_interval(r, len(pairs)) if not constant else (None, None)
            lo_hi = fisher_interval(rho, len(pairs), spearman=True) if not constant else (None, None)
            rec["spearman_low"], rec["spearman_high"] = lo_hi
            out.append(rec)
    return out


# -- the section -----------------------------------------------------------------------------


def _ci(rec, lo="ci_low", hi="ci_high", key="mean", digits=1) -> str:
    if rec.get(key) is None or (isinstance(rec[key], float) and math.isnan(rec[key])):
        return "–"
    if rec.get(lo) is None:
        return fmt(rec[key], digits)
    return f"{fmt(rec[key], digits)} [{fmt(rec[lo], digits)}, {fmt(rec[hi], digits)}]"


def _screening_lines(screen) -> list[str]:
    body = [[s["method"], s["listener"], f"{s['failed']} of {s['checked']}", "excluded" if s["excluded"] else "kept"]
            for s in screen]  # fmt: skip
    return ["### Listener screening", "",
            f"MUSHRA: hidden reference below {MUSHRA_REFERENCE_MIN:g} in more than {MAX_FAILED_FRACTION:.0%} of "
            f"the trials excludes a listener (BS.1534-3); P.835: the clean reference's BAK rated below the "
            f"mixture's in more than {MAX_FAILED_FRACTION:.0%} of the conditions.", "",
            markdown_table(["method", "listener", "failed checks", "verdict"], body), ""]  # fmt: skip


def _means_lines(means) -> list[str]:
    lines = ["### Mean ratings", "",
             "Mean over the kept listeners [95 % Student-t interval], `n` listeners; P.835 scales 1-5, MUSHRA 0-100.", ""]  # fmt: skip
    for method, scale in sorted({(m["method"], m["scale"]) for m in means}):
        recs = [m for m in means if (m["method"], m["scale"]) == (method, scale)]
        conds = sorted({m["condition_id"] for m in recs})
        cell = {(m["system"], m["condition_id"]): m for m in recs}
        body = [[f"`{s}`", *(_ci(cell[(s, c)], digits=2 if method == "p835" else 1) + f" (n={cell[(s, c)]['n']})"
                             if (s, c) in cell else "–" for c in conds)] for s in sorted({m["system"] for m in recs})]  # fmt: skip
        lines += [f"**{method} {scale.upper()}**", "", markdown_table(["system", *(f"`{c}`" for c in conds)], body), ""]
    return lines


def _pairs_lines(pairs) -> list[str]:
    body = [[p["method"], p["scale"].upper(), f"`{p['b']}` − `{p['a']}`", str(p["n"]),
             _ci(p, key="mean_diff", digits=2), f"{p['p']:.3g}", f"{p['p_holm']:.3g}",
             "separated" if p["separated"] else "not separated"] for p in pairs]  # fmt: skip
    return ["### Paired comparisons", "",
            "Paired t over (listener, condition) cells, Holm-corrected over the pairs of a scale; "
            f"separated when p_holm < {ALPHA:g}.", "",
            markdown_table(["method", "scale", "difference", "n", "mean [95 % CI]", "p", "p_holm", ""], body), ""]  # fmt: skip


def _agreement_lines(agree) -> list[str]:
    body = [[a["label"], f"{a['method']} {a['scale'].upper()}", str(a["n"]),
             _ci(a, "pearson_low", "pearson_high", "pearson", 2),
             _ci(a, "spearman_low", "spearman_high", "spearman", 2)] for a in agree]  # fmt: skip
    return ["### How well each metric predicts the ratings", "",
            "Over clips (condition, system): the metric of the stored row against the mean rating of the kept "
            "listeners. Pearson's r [Fisher-z 95 % interval]; Spearman's rho [Fisher-z interval with "
            "variance 1.06/(n-3), Fieller et al. 1957]. A handful of clips gives wide intervals.", "",
            markdown_table(["metric", "scale", "clips", "Pearson r", "Spearman rho"], body), ""]  # fmt: skip


def ratings_section(ctx) -> tuple[list[str], list[Path]]:
    """The "Listening test" section of the report for a :class:`benchmarks.report.core.ReportContext`
    (its store is ``ctx.report_dir``'s parent); nothing when the store holds no ratings."""
    ratings = load_ratings(Path(ctx.report_dir).parent)
    if not ratings:
        return [], []
    screen, kept = screen_listeners(ratings), retained(ratings)
    means, pairs, agree = rating_means(kept), paired_comparisons(kept), metric_agreement(kept, ctx.ok)
    d = Path(ctx.report_dir)
    files = [
        write_csv(d / "ratings_screening.csv", screen, ["method", "listener", "checked", "failed", "excluded"]),
        write_csv(d / "ratings_means.csv", means, list(means[0]) if means else ["method"]),
        write_csv(d / "ratings_pairs.csv", pairs, ["method", "scale", "a", "b", "n", "mean_diff", "ci_low",
                                                    "ci_high", "p", "p_holm", "separated"]),  # fmt: skip
        write_csv(d / "ratings_agreement.csv", agree, ["metric", "method", "scale", "n", "pearson", "pearson_low",
                                                        "pearson_high", "spearman", "spearman_low", "spearman_high"]),  # fmt: skip
    ]
    n_listeners = len({r["listener"] for r in ratings})
    lines = ["## Listening test", "",
             f"{len(ratings)} ratings from {n_listeners} listener(s) (`scenesim listen`; docs/listening.md says what "
             "a handful of untrained listeners on unknown playback can and cannot show).", "",
             *_screening_lines(screen), *_means_lines(means)]  # fmt: skip
    lines += _pairs_lines(pairs) if pairs else []
    lines += _agreement_lines(agree) if agree else []
    return lines, files


__all__ = [
    "ALPHA",
    "MAX_FAILED_FRACTION",
    "METRICS",
    "MUSHRA_REFERENCE_MIN",
    "fisher_interval",
    "holm",
    "load_ratings",
    "metric_agreement",
    "paired_comparisons",
    "rating_means",
    "ratings_section",
    "retained",
    "screen_listeners",
    "t_interval",
]
