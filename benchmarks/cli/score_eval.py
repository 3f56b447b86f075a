"""``scenesim score --out``'s evaluation: per-system summary, paired comparisons, versions.

From the per-file rows of :func:`benchmarks.metrics.scoring.score_files` (status ``ok`` rows
and non-empty values only):

* **summary** (``OUT.summary.csv``): per system and metric the number of files ``n``, the
  mean, the median and the 95 % Student-t interval of the mean over files,
  ``mean -/+ t_{0.975, n-1} s / sqrt(n)`` (:func:`benchmarks.report.tables.ci95_halfwidth`;
  none for ``n < 2``);
* **paired comparisons** (``OUT.paired.csv``): for every two systems A, B (A listed first) and
  every metric, over the utterances both scored, the mean paired difference ``B - A`` with its
  95 % paired Student-t interval (:func:`benchmarks.report.compare.paired_ci`, equal to
  ``scipy.stats.ttest_rel(B, A).confidence_interval()``).  Pairing removes the utterance's own
  difficulty from the comparison, which the two marginal intervals of the summary keep;
* **versions** (``OUT.json``, a JSON sidecar): scenesim, the metric packages (``pesq``,
  ``pystoi``; ``speechmos``, ``onnxruntime`` and the SHA-256 of the DNSMOS model files when
  DNSMOS ran), the options, the counts and the names of the files written.

Example
-------
>>> rows = [{"system": s, "utterance": u, "status": "ok", "stoi": v}
...         for s, vals in (("a", (0.5, 0.6, 0.7)), ("b", (0.6, 0.8, 0.8))) for u, v in zip("xyz", vals)]
>>> [round(r["mean"], 3) for r in system_summary(rows, ["stoi"])]
[0.6, 0.733]
>>> c = paired_comparisons(rows, ["stoi"])[0]
>>> c["system_a"], c["system_b"], c["n"], round(c["mean_diff"], 3)
('a', 'b', 3, 0.133)
"""

from __future__ import annotations

import csv
import json
import platform
import statistics
from collections.abc import Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import scenesim
from benchmarks.metrics.scoring import INTRUSIVE, NON_INTRUSIVE
from benchmarks.report.compare import paired_ci
from benchmarks.report.tables import ci95_halfwidth, mean_std

__all__ = ["PAIRED_COLUMNS", "SUMMARY_COLUMNS", "output_paths", "paired_comparisons", "system_summary",
           "versions", "write_csv", "write_evaluation"]

SUMMARY_COLUMNS = ("system", "metric", "n", "mean", "median", "ci_low", "ci_high")
PAIRED_COLUMNS = ("metric", "system_a", "system_b", "n", "mean_a", "mean_b", "mean_diff", "ci_low", "ci_high")
_PACKAGES = ("numpy", "scipy", "soundfile", "pesq", "pystoi")
_DNSMOS_PACKAGES = ("speechmos", "onnxruntime")


def _values(rows: Sequence[Mapping], metric: str, system: str) -> dict[str, float]:
    """``{utterance: value}`` of one system's ok rows where ``metric`` has a value."""
    return {r["utterance"]: float(r[metric]) for r in rows
            if r["system"] == system and r.get("status") == "ok" and r.get(metric) not in (None, "")}


def _systems(rows: Sequence[Mapping]) -> list[str]:
    return list(dict.fromkeys(r["system"] for r in rows))


def metrics_present(rows: Sequence[Mapping]) -> list[str]:
    """The metric columns holding at least one value, in the CSV's order."""
    return [m for m in (*INTRUSIVE, *NON_INTRUSIVE) if any(r.get(m) not in (None, "") for r in rows)]


def system_summary(rows: Sequence[Mapping], metrics: Sequence[str]) -> list[dict[str, Any]]:
    """Per system and metric: ``n``, ``mean``, ``median``, ``ci_low``/``ci_high`` (module docstring)."""
    out = []
    for system in _systems(rows):
        for metric in metrics:
            values = list(_values(rows, metric, system).values())
            mean, sd, n = mean_std(values)
            half = ci95_halfwidth(sd, n)
            out.append({"system": system, "metric": metric, "n": n, "mean": mean,
                        "median": statistics.median(values) if values else None,
                        "ci_low": None if half is None else mean - half,
                        "ci_high": None if half is None else mean + half})
    return out


def paired_comparisons(rows: Sequence[Mapping], metrics: Sequence[str]) -> list[dict[str, Any]]:
    """Every two systems A, B and metric: ``B - A`` over common utterances (module docstring)."""
    systems = _systems(rows)
    out = []
    for metric in metrics:
        per_system = {s: _values(rows, metric, s) for s in systems}
        for i, a in enumerate(systems):
            for b in systems[i + 1:]:
                common = sorted(set(per_system[a]) & set(per_system[b]))
                stat = paired_ci([per_system[a][u] for u in common], [per_system[b][u] for u in common])
                out.append({"metric": metric, "system_a": a, "system_b": b, "n": stat.n,
                            "mean_a": stat.mean_a, "mean_b": stat.mean_b, "mean_diff": stat.mean_diff,
                            "ci_low": stat.ci_low, "ci_high": stat.ci_high})
    return out


def _version(package: str) -> str | None:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def versions(*, dnsmos: bool) -> dict[str, Any]:
    """Versions of scenesim, Python and the metric packages; with DNSMOS its models' SHA-256."""
    found = {"scenesim": scenesim.__version__, "python": platform.python_version()}
    found.update({p: _version(p) for p in (*_PACKAGES, *(_DNSMOS_PACKAGES if dnsmos else ()))})
    if dnsmos:
        from benchmarks.metrics.dnsmos import model_digests

        found["dnsmos_models_sha256"] = model_digests()
    return found


def output_paths(out: Path) -> dict[str, Path]:
    """The files ``--out OUT`` writes: the rows, ``.summary.csv``, ``.paired.csv`` and ``.json``."""
    out = Path(out)
    stem = out.with_suffix("") if out.suffix.lower() == ".csv" else out
    return {"rows": out, "summary": Path(f"{stem}.summary.csv"), "paired": Path(f"{stem}.paired.csv"),
            "versions": Path(f"{stem}.json")}


def write_csv(path_or_stream, rows: Sequence[Mapping], columns: Sequence[str]) -> None:
    """``rows`` as CSV with ``columns`` (None written as an empty cell)."""
    def _write(stream):
        writer = csv.DictWriter(stream, fieldnames=list(columns), extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in columns})

    if hasattr(path_or_stream, "write"):
        _write(path_or_stream)
        return
    with open(path_or_stream, "w", newline="", encoding="utf-8") as stream:
        _write(stream)


def write_evaluation(out: Path, rows: Sequence[Mapping], columns: Sequence[str], *, dnsmos: bool,
                     options: Mapping[str, Any]) -> dict[str, Path]:
    """Write the four files of :func:`output_paths`; returns them."""
    paths = output_paths(out)
    metrics = metrics_present(rows)
    write_csv(paths["rows"], rows, columns)
    write_csv(paths["summary"], system_summary(rows, metrics), SUMMARY_COLUMNS)
    write_csv(paths["paired"], paired_comparisons(rows, metrics), PAIRED_COLUMNS)
    failed = sum(r.get("status") != "ok" for r in rows)
    record = {"versions": versions(dnsmos=dnsmos), "options": dict(options),
              "files": {"scored": len(rows) - failed, "failed": failed},
              "interval": "95 % Student t over files (summary); paired Student t over common utterances "
                          "(comparisons, B - A)",
              "outputs": {k: str(v) for k, v in paths.items()}}
    paths["versions"].write_text(json.dumps(record, indent=2, default=str) + "\n", encoding="utf-8")
    return paths
