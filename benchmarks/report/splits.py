"""The data split(s) of a report's rows (:mod:`data_recipes.splits`), named where its numbers are.

A row drew its speech and noise from ``dev``, ``test`` or ``all`` (column ``split``; rows from
stores written before splits existed count as ``all``).  The report names the split in its header,
under every section heading and in every figure caption; rows of several splits are named as
``splits: dev+test`` and said to be averaged together, never silently.

>>> split_label([{"split": "dev"}, {"split": "dev"}])
'split: dev'
>>> split_label([{"split": "test"}, {"split": "dev"}, {}])
'splits: dev+test+all'
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

_ORDER = ("dev", "test", "all")
#: Section headings that show no number of the rows (no split caption under them).
_NO_CAPTION = ("## Contents", "## Files")


def split_names(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The distinct splits of ``rows``, dev, test, all first (a missing value is ``all``)."""
    found = {str(r.get("split") or "all") for r in rows}
    return sorted(found, key=lambda s: (_ORDER.index(s) if s in _ORDER else len(_ORDER), s))


def split_label(rows: Sequence[Mapping[str, Any]]) -> str:
    """``"split: dev"``, or ``"splits: dev+test"`` when the rows mix splits (``"split: none"`` without rows)."""
    names = split_names(rows)
    if not names:
        return "split: none"
    return ("split: " if len(names) == 1 else "splits: ") + "+".join(names)


def header_line(rows: Sequence[Mapping[str, Any]]) -> str:
    """The report header's line naming the split(s); a mix is said to be averaged together."""
    names = split_names(rows)
    if len(names) <= 1:
        return f"- **split**: {names[0] if names else 'none'}"
    return (f"- **splits**: {'+'.join(names)} -- **rows of different data splits are averaged together "
            "below**; run each split into its own --out to report them apart")


def captioned(lines: Sequence[str], label: str) -> list[str]:
    """``lines`` with ``*label*`` under every ``## `` heading that shows numbers.

    >>> captioned(["## Averages", "", "| a |"], "split: dev")[:3]
    ['## Averages', '', '*split: dev*']
    """
    out: list[str] = []
    for line in lines:
        out.append(line)
        if line.startswith("## ") and line.strip() not in _NO_CAPTION:
            out += ["", f"*{label}*"]
    return out
