"""``benchmarks.load_results(DIR)``: a store's rows as a pandas DataFrame, for notebooks.

pandas is optional (it is in the ``dev`` extra, not a runtime dependency): without it
:func:`load_results` raises :class:`scenesim.errors.ScenesimError` with the one line
that installs it.
"""

from __future__ import annotations

from pathlib import Path

from benchmarks.store.sqlite import COLUMNS, ResultStore
from scenesim.errors import ScenesimError

PANDAS_MISSING = "benchmarks.load_results needs pandas: pip install pandas"

#: A sweep's axis names (TOML ``[axes]``) and the store columns holding them; both spellings
#: are accepted as filters by :func:`load_results` (and :func:`column_name` maps them).
COLUMN_ALIASES = {"snr_db": "snr_in_db", "enhancers": "enhancer", "seeds": "seed", "noises": "noise"}


def column_name(name: str) -> str:
    """The store column of a sweep axis name (store names pass through).

    >>> column_name("snr_db"), column_name("enhancers"), column_name("rt60_s")
    ('snr_in_db', 'enhancer', 'rt60_s')
    """
    return COLUMN_ALIASES.get(name, name)


def _pandas():
    try:
        import pandas
    except ImportError:
        raise ScenesimError(PANDAS_MISSING) from None
    return pandas


def _check_values_present(key: str, wanted: set, present: set, out_dir) -> None:
    """A filter value no stored row holds is a typo (``enhancers="eb-sss"``, ``snr_db="0"``), not an empty
    selection: say which values the column has."""
    missing = [w for w in wanted if w not in present]
    if present and missing:
        have = ", ".join(sorted(repr(v) for v in present if v is not None)[:12])
        raise ScenesimError(f"load_results: {key}={missing[0]!r} matches no row in {out_dir} (values: {have})")


def load_results(out_dir: str | Path, *, ok_only: bool = False, **where):
    """Every row of ``out_dir/results.sqlite`` as a :class:`pandas.DataFrame`.

    Parameters
    ----------
    out_dir : path
        A sweep's output directory (the one ``scenesim bench run --out`` wrote).
    ok_only : bool
        Keep only rows with ``status == 'ok'`` (error rows have empty metrics).
    **where
        Filters ``column=value`` or ``column=[values]``, by store column or by the sweep's
        axis name (:data:`COLUMN_ALIASES`: ``snr_db``, ``enhancers``, ``seeds``, ``noises``).

    Returns
    -------
    pandas.DataFrame
        One row per (condition, enhancer) in insertion order; the store's columns in its
        order (contract columns first, e.g. ``condition_id, enhancer, noise, snr_in_db,
        ..., snr_i_db, pesq_nb_out, ...``); missing values are NaN/None.

    Examples
    --------
    >>> df = load_results("results/thesis")                          # doctest: +SKIP
    >>> df = load_results("results/thesis", snr_db=[0, 5], enhancers="eb")  # doctest: +SKIP
    >>> df.groupby(["enhancer", "noise"])["snr_i_db"].mean()          # doctest: +SKIP
    """
    pd = _pandas()
    with ResultStore.open(out_dir, readonly=True) as store:
        rows = store.rows("status = 'ok'") if ok_only else store.rows()
    stored = rows  # a value is checked against the whole store, not what earlier filters left
    for key, want in where.items():
        col = column_name(key)
        if rows and col not in rows[0]:
            raise ScenesimError(f"load_results: no column {key!r} in {out_dir} (axis names accepted: {', '.join(COLUMN_ALIASES)})")
        wanted = set(want) if isinstance(want, (list, tuple, set)) else {want}
        _check_values_present(key, wanted, {r.get(col) for r in stored}, out_dir)
        rows = [r for r in rows if r.get(col) in wanted]
    columns = [c for c in COLUMNS if not rows or c in rows[0]]
    columns += [c for c in (rows[0] if rows else ()) if c not in columns]
    return pd.DataFrame.from_records(rows, columns=columns)


__all__ = ["COLUMN_ALIASES", "PANDAS_MISSING", "column_name", "load_results"]
