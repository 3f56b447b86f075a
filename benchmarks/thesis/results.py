"""The thesis protocol's results file (``DIR/thesis_search.json``, with ``thesis_identifiability.csv``
beside it) and its printout.

``scenesim thesis search --out DIR`` writes both; :func:`find_results` is how the report looks for them.

>>> block = {"score": "s", "rule": "r", "rows": [{"label": "x", "score": 1.0, "diff_lo": 0.0, "diff_hi": 0.0,
...          "in_set": True}], "agreement": {"adapt": ["slow"]}, "n_set": 1, "n_readings": 1}
>>> ident_lines(block, "EB")[-1]
'  agreed: adapt=slow; not identified: none'
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

from benchmarks.thesis.protocol import RESULTS_NAME

CSV_NAME = "thesis_identifiability.csv"
ENV = "SCENESIM_THESIS_SEARCH"
"""A results file (or its folder) the report reads instead of looking next to the store."""
DEFAULT_OUT = "thesis-search"
"""``scenesim thesis search``'s default ``--out``."""


def write_results(result: Mapping, out_dir) -> list[Path]:
    """Write ``result`` (:func:`benchmarks.thesis.protocol.run_protocol`'s) as JSON and the
    identifiability rows as CSV under ``out_dir``; returns the two paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / RESULTS_NAME
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(_clean(result), indent=1, default=str, allow_nan=False), encoding="utf-8")
    os.replace(tmp, path)  # a reader never sees half a file
    rows = [{"block": name, "rank": i + 1, **{k: v for k, v in r.items() if k != "reading"}, **r["reading"]}
            for name in ("eb", "ss") for i, r in enumerate(result["identifiability"][name]["rows"])]
    csv_path = out / CSV_NAME
    with open(csv_path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["block"])
        writer.writeheader()
        writer.writerows(rows)
    return [path, csv_path]


def _clean(value):
    """``value`` with every non-finite float as None (valid JSON, the report's "no value")."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def find_results(near=None) -> Path | None:
    """The results file: ``$SCENESIM_THESIS_SEARCH`` (a file or folder), else ``near/thesis_search.json``
    or ``near/thesis-search/thesis_search.json`` (``near``: e.g. a store folder), else the same under the
    current folder; None when there is none."""
    env = os.environ.get(ENV, "").strip()
    candidates = [Path(env), Path(env) / RESULTS_NAME] if env else []
    for base in ([Path(near)] if near is not None else []) + [Path.cwd()]:
        candidates += [base / RESULTS_NAME, base / DEFAULT_OUT / RESULTS_NAME]
    return next((p for p in candidates if p.is_file()), None)


def load_results(path) -> dict:
    """The JSON of a results file."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


def _f(v, digits=2) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def held_out_lines(result: Mapping) -> list[str]:
    """In-sample against held-out mean |dSNR-I| and |d raw PESQ|, one line per direction."""
    lines = [f"Held-out error (chosen on {result['choose_split']} material and one family of tables, scored on "
             f"{result['score_split']} material and the other family):",
             f"  {'chosen on':14s} {'scored on':14s} {'in-sample dSNR-I':>16s} {'dPESQ':>6s} "
             f"{'held-out dSNR-I':>15s} {'dPESQ':>6s}  reading"]
    for h in result["held_out"]:
        a, b = h["in_sample"], h["held_out"]
        lines.append(f"  {'+'.join(h['chosen_on']):14s} {'+'.join(h['scored_on']):14s} {_f(a['snr_i']):>16s} "
                     f"{_f(a['pesq'], 3):>6s} {_f(b['snr_i']):>15s} {_f(b['pesq'], 3):>6s}  {h['label']}")
    fit, preset = result["fit"], result["preset"]
    lines += [f"  fit on all dev tables, in-sample {_f(fit['in_sample']['snr_i'])} dB / {_f(fit['in_sample']['pesq'], 3)}; "
              f"on test material {_f(fit['test_all_tables']['snr_i'])} dB / {_f(fit['test_all_tables']['pesq'], 3)}",
              f"  the preset's reading (BEST) on test material: {_f(preset['test_all_tables']['snr_i'])} dB / "
              f"{_f(preset['test_all_tables']['pesq'], 3)}"]
    return lines


def ident_lines(block: Mapping, name: str) -> list[str]:
    """One block's identifiability table: score, paired interval against the best, membership."""
    lines = [f"Identifiability, {name} unknowns ({block['score']}): {block['n_set']} of {block['n_readings']} "
             "readings in the set",
             f"  {'score':>6s} {'diff 95% interval':>18s} {'set':>3s}  reading"]
    for r in block["rows"]:
        lines.append(f"  {r['score']:6.3f} [{r['diff_lo']:7.3f}, {r['diff_hi']:6.3f}] {'yes' if r['in_set'] else 'no':>3s}"
                     f"  {r['label']}")
    agreed = [f"{u}={v[0]}" for u, v in block["agreement"].items() if len(v) == 1]
    loose = [f"{u} ({', '.join(v)})" for u, v in block["agreement"].items() if len(v) > 1]
    lines.append(f"  agreed: {', '.join(agreed) or 'none'}; not identified: {', '.join(loose) or 'none'}")
    return lines


def protocol_lines(result: Mapping) -> list[str]:
    """The protocol's printout after the search's own: held-out error, both identifiability tables."""
    ident = result["identifiability"]
    return [*held_out_lines(result), "", f"Rule: {ident['rule']}; seeds {ident_seeds(result)}.",
            *ident_lines(ident["eb"], "EB"), "", *ident_lines(ident["ss"], "SS and measurement"),
            "", f"Protocol time: {result['seconds']:.0f} s"]


def ident_seeds(result: Mapping) -> str:
    seeds = result["ident_seeds"]
    return f"{seeds[0]}..{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])
