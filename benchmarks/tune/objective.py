"""What ``scenesim tune`` optimises: an objective and constraints over results-store columns.

Objective ``AGG:COLUMN`` (``mean:snr_i_db``, ``median:speech_jitter_db``): the mean (or median)
of ``COLUMN`` over the trial's rows with ``status = 'ok'`` and a value in that column.

Constraint ``COLUMN<=BOUND`` or ``COLUMN>=BOUND``, optionally restricted to rows meeting a
filter after ``@`` (``speech_jitter_db<=-30@snr_in_db>=15``: jitter at most -30 dB in every
row whose input SNR is at least 15 dB).  Its value, as Optuna's ``constraints_func`` wants
it (feasible when <= 0), is the **largest violation** over the selected rows, in the column's
unit: ``max(value - BOUND)`` for ``<=``, ``max(BOUND - value)`` for ``>=``.  A constraint
whose filter selects no row is met vacuously (value ``-inf``, shown as such in the progress).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenesim.errors import ParameterError

AGGREGATES = ("mean", "median")
_COMPARISON = re.compile(r"^\s*([a-z0-9_]+)\s*(<=|>=)\s*([-+0-9.eE]+|[-+]?inf)\s*$")


def numeric_columns() -> tuple[str, ...]:
    """The store's REAL and INTEGER columns: what an objective or a constraint may read."""
    from benchmarks.store.sqlite import CONTRACT_COLUMNS, EXTRA_COLUMNS

    return tuple(n for n, t in CONTRACT_COLUMNS + EXTRA_COLUMNS if t.split()[0] in ("REAL", "INTEGER"))


def _check_column(option: str, text: str, column: str) -> str:
    if column not in numeric_columns():
        raise ParameterError(option, text, f"a numeric results column, e.g. snr_i_db, pesq_nb_i, stoi_i, speech_jitter_db (got {column!r})")
    return column


@dataclass(frozen=True)
class Objective:
    """``AGG:COLUMN`` over a trial's ok rows.

    >>> Objective.parse("mean:snr_i_db").value([{"status": "ok", "snr_i_db": 2.0}, {"status": "ok", "snr_i_db": 4.0}])
    3.0
    """

    aggregate: str
    column: str

    @property
    def text(self) -> str:
        return f"{self.aggregate}:{self.column}"

    @classmethod
    def parse(cls, text: str) -> Objective:
        agg, sep, column = str(text).partition(":")
        if not sep or agg not in AGGREGATES:
            raise ParameterError("--objective", text, f"AGG:COLUMN with AGG one of {', '.join(AGGREGATES)}, e.g. mean:snr_i_db")
        return cls(agg, _check_column("--objective", text, column.strip()))

    def value(self, rows: Sequence[Mapping[str, Any]]) -> float | None:
        """The aggregate over ok rows with a value; None when there is none (the trial failed)."""
        values = column_values(rows, self.column)
        if not values.size:
            return None
        return float(np.mean(values) if self.aggregate == "mean" else np.median(values))


@dataclass(frozen=True)
class Comparison:
    column: str
    op: str  # "<=" or ">="
    bound: float

    @classmethod
    def parse(cls, option: str, text: str, part: str) -> Comparison:
        m = _COMPARISON.match(part)
        if not m:
            raise ParameterError(option, text, "COLUMN<=VALUE or COLUMN>=VALUE, optionally @COLUMN<=VALUE|>=VALUE, e.g. speech_jitter_db<=-30@snr_in_db>=15")
        return cls(_check_column(option, text, m.group(1)), m.group(2), float(m.group(3)))

    def holds(self, value: float) -> bool:
        return value <= self.bound if self.op == "<=" else value >= self.bound

    def excess(self, value: float) -> float:
        """How far ``value`` is on the wrong side of the bound (<= 0: it holds)."""
        return value - self.bound if self.op == "<=" else self.bound - value

    @property
    def text(self) -> str:
        return f"{self.column}{self.op}{self.bound:g}"


@dataclass(frozen=True)
class Constraint:
    """``COLUMN<=BOUND[@FILTER]``: its value is the largest violation over the selected rows.

    >>> c = Constraint.parse("speech_jitter_db<=-30@snr_in_db>=15")
    >>> rows = [{"status": "ok", "snr_in_db": 15.0, "speech_jitter_db": -28.0},
    ...         {"status": "ok", "snr_in_db": 0.0, "speech_jitter_db": -5.0}]
    >>> c.value(rows)
    2.0
    """

    test: Comparison
    where: Comparison | None = None

    @property
    def text(self) -> str:
        return self.test.text + (f"@{self.where.text}" if self.where else "")

    @classmethod
    def parse(cls, text: str) -> Constraint:
        test, sep, where = str(text).partition("@")
        return cls(Comparison.parse("--constraint", text, test),
                   Comparison.parse("--constraint", text, where) if sep else None)

    def selected(self, rows: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
        """The ok rows the filter keeps that have a value in the constrained column."""
        keep = []
        for r in rows:
            if r.get("status") != "ok" or _number(r.get(self.test.column)) is None:
                continue
            w = None if self.where is None else _number(r.get(self.where.column))
            if self.where is None or (w is not None and self.where.holds(w)):
                keep.append(r)
        return keep

    def value(self, rows: Sequence[Mapping[str, Any]]) -> float:
        """``max`` over the selected rows of the violation; ``-inf`` when none is selected."""
        excess = [self.test.excess(float(r[self.test.column])) for r in self.selected(rows)]
        return float(max(excess)) if excess else -math.inf


def _number(value) -> float | None:
    if value is None:
        return None
    value = float(value)
    return None if math.isnan(value) else value


def column_values(rows: Sequence[Mapping[str, Any]], column: str) -> np.ndarray:
    """``column`` of the ok rows that have a value there (NULL/NaN left out), as float64."""
    return np.array([float(r[column]) for r in rows if r.get("status") == "ok" and _number(r.get(column)) is not None],
                    dtype=np.float64)
