"""The results store: ``DIR/results.sqlite`` (contract.md, "Results store": fixed names).

Table ``results`` holds one row per (condition, enhancer) with the contract's columns plus
extras (ESTOI, segmental SNR, SI-SDR, the EB trace, timings, the condition and enhancer
specs, versions).  Table ``runs`` records each invocation (config, versions, executor,
start/end, status).

Crash safety: the database is in WAL mode with ``synchronous=NORMAL``; the rows of one
finished condition are written in one transaction, so a ``kill -9`` loses at most the
conditions still in flight and never leaves half a condition.  Only the driver process
writes (workers return rows), so there is one writer.  ``INSERT ... ON CONFLICT DO UPDATE``
on ``UNIQUE(condition_id, enhancer)`` makes a rerun of the same condition replace its rows,
never duplicate them.
"""

from __future__ import annotations

import json
import logging
import socket
import sqlite3
import uuid
from collections.abc import Iterable, Mapping, Sequence
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

from benchmarks.store.errors import store_errors
from scenesim.errors import DataError

log = logging.getLogger(__name__)

STORE_NAME = "results.sqlite"

CONTRACT_COLUMNS: tuple[tuple[str, str], ...] = (
    ("condition_id", "TEXT NOT NULL"),
    ("enhancer", "TEXT NOT NULL"),
    ("noise", "TEXT"),
    ("snr_in_db", "REAL"),
    ("rt60_s", "REAL"),
    ("speech_az_deg", "REAL"),
    ("noise_az_deg", "REAL"),
    ("seed", "INTEGER"),
    ("snr_out_db", "REAL"),
    ("snr_i_db", "REAL"),
    ("pesq_nb_in", "REAL"),
    ("pesq_nb_out", "REAL"),
    ("pesq_wb_in", "REAL"),
    ("pesq_wb_out", "REAL"),
    ("stoi_in", "REAL"),
    ("stoi_out", "REAL"),
    ("speech_source", "TEXT"),
    ("noise_source", "TEXT"),
    ("status", "TEXT NOT NULL"),
    ("error", "TEXT"),
)
"""The contract's columns, in its order (names and types fixed)."""

EXTRA_COLUMNS: tuple[tuple[str, str], ...] = (
    ("estoi_in", "REAL"),
    ("estoi_out", "REAL"),
    ("segsnr_in_db", "REAL"),
    ("segsnr_out_db", "REAL"),
    ("si_sdr_in_db", "REAL"),
    ("si_sdr_out_db", "REAL"),
    ("snr_in_db_measured", "REAL"),
    ("pesq_nb_i", "REAL"),
    ("pesq_wb_i", "REAL"),
    ("stoi_i", "REAL"),
    ("estoi_i", "REAL"),
    ("segsnr_i_db", "REAL"),
    ("si_sdr_i_db", "REAL"),
    ("latency_samples", "INTEGER"),
    ("latency_est_samples", "INTEGER"),
    ("latency_check", "TEXT"),
    ("snr_method", "TEXT"),
    ("warnings", "TEXT"),
    ("trace_json", "TEXT"),
    ("process_s", "REAL"),
    ("metrics_s", "REAL"),
    ("render_s", "REAL"),
    ("room", "TEXT"),
    ("distance_m", "REAL"),
    ("noise_distance_m", "REAL"),
    ("noise_field", "TEXT"),
    ("fs", "INTEGER"),
    ("duration_s", "REAL"),
    ("far_field", "INTEGER"),
    ("spacing_m", "REAL"),
    ("wind_speed_mps", "REAL"),
    ("snr_band_lo_hz", "REAL"),
    ("snr_band_hi_hz", "REAL"),
    # the sensors each row was computed with (drawn values; scenesim.scene.sensors)
    ("ideal_sensors", "INTEGER"),
    ("mic_gain_db", "REAL"),
    ("mic_phase_deg", "REAL"),
    ("mic_front_gain_db", "REAL"),
    ("mic_rear_gain_db", "REAL"),
    ("mic_front_highpass_hz", "REAL"),
    ("mic_rear_highpass_hz", "REAL"),
    ("self_noise_dba", "REAL"),
    ("speech_spl_db", "REAL"),
    # room acoustics of the speech RIR at the reference mic, and targets (benchmarks.metrics.reverb)
    ("t30_s", "REAL"),
    ("edt_s", "REAL"),
    ("drr_rir_db", "REAL"),
    ("c50_rir_db", "REAL"),
    ("rt60_target_s", "REAL"),
    ("drr_rir_target_db", "REAL"),
    ("c50_rir_target_db", "REAL"),
    ("critical_distance_m", "REAL"),
    ("t_speech_s", "REAL"),
    ("edt_speech_s", "REAL"),
    ("t_mid_s", "REAL"),
    ("edt_mid_s", "REAL"),
    ("d50_rir", "REAL"),
    ("d50_rir_target", "REAL"),
    ("drr_win_rir_db", "REAL"),
    ("drr_win_rir_target_db", "REAL"),
    ("sweep_version", "TEXT"),
    # the data split a row drew from (data_recipes.splits) and the files its clips were cut from
    ("split", "TEXT"),
    ("speech_files", "TEXT"),
    ("noise_files", "TEXT"),
    ("group_id", "TEXT"),
    ("condition_json", "TEXT"),
    ("enhancer_spec", "TEXT"),
    ("enhancer_version", "TEXT"),
    ("scenesim_version", "TEXT"),
    ("worker", "TEXT"),
    ("run_id", "TEXT"),
    ("created_at", "TEXT"),
)
"""More columns (contract.md: "More columns are welcome")."""



def _evaluate_columns() -> tuple[tuple[str, str], ...]:
    """Columns of :data:`benchmarks.metrics.evaluate.ROW_COLUMNS` not listed above (kept in step with it)."""
    from benchmarks.metrics.evaluate import ROW_COLUMNS

    have = {n for n, _ in CONTRACT_COLUMNS + EXTRA_COLUMNS}
    return tuple((n, t) for n, t in ROW_COLUMNS.items() if n not in have)


def _optional_metric_columns() -> tuple[tuple[str, str], ...]:
    """Columns of the metrics a sweep opts into (``metrics = ["dnsmos"]``); empty in other sweeps."""
    from benchmarks.metrics.dnsmos import COLUMNS as DNSMOS_COLUMNS

    return tuple(DNSMOS_COLUMNS.items())


EXTRA_COLUMNS = EXTRA_COLUMNS + _evaluate_columns() + _optional_metric_columns()
COLUMNS: tuple[str, ...] = tuple(name for name, _ in CONTRACT_COLUMNS + EXTRA_COLUMNS)

RUN_COLUMNS: tuple[tuple[str, str], ...] = (
    ("run_id", "TEXT PRIMARY KEY"),
    ("sweep", "TEXT"),
    ("source", "TEXT"),
    ("config_toml", "TEXT"),
    ("options_json", "TEXT"),
    ("versions_json", "TEXT"),
    ("executor", "TEXT"),
    ("workers", "INTEGER"),
    ("scheduler", "TEXT"),
    ("data_dir", "TEXT"),
    ("hostname", "TEXT"),
    ("started_at", "TEXT"),
    ("finished_at", "TEXT"),
    ("status", "TEXT"),
    ("n_rows_written", "INTEGER"),
    ("n_errors", "INTEGER"),
)

#: Table ``ratings``: one listener's rating of one clip on one scale (``scenesim listen``), written as
#: it is given.  ``system`` is an enhancer name or a hidden anchor (``reference``, ``mixture``,
#: ``anchor-lp3.5k``); ``scale`` is ``sig``/``bak``/``ovrl`` (ITU-T P.835, 1-5) or ``mushra`` (0-100).
RATING_COLUMNS: tuple[tuple[str, str], ...] = (
    ("listener", "TEXT NOT NULL"),
    ("method", "TEXT NOT NULL"),
    ("condition_id", "TEXT NOT NULL"),
    ("system", "TEXT NOT NULL"),
    ("scale", "TEXT NOT NULL"),
    ("rating", "REAL NOT NULL"),
    ("trial", "INTEGER"),
    ("session_seed", "INTEGER"),
    ("rated_at", "TEXT"),
)
#: Layout version of ``ratings`` (``meta`` key ``ratings_schema``): a store written by a newer
#: layout is refused rather than misread.
RATINGS_SCHEMA_VERSION = 1

VERSIONED_PACKAGES = ("scenesim", "numpy", "scipy", "pesq", "pystoi", "pyroomacoustics")


def package_versions(names: Sequence[str] = VERSIONED_PACKAGES) -> dict[str, str | None]:
    """Installed versions of the packages that decide the numbers (None when absent)."""
    out: dict[str, str | None] = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def utc_now() -> str:
    """ISO-8601 UTC timestamp with microseconds (distinguishes rows written moments apart)."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


class ResultStore:
    """``DIR/results.sqlite``; open with :meth:`open` or as a context manager.

    Parameters
    ----------
    path : path-like
        The database file (``open(out_dir)`` gives ``out_dir/results.sqlite``).
    readonly : bool
        Open an existing store for reading only (``bench report``).
    """

    def __init__(self, path: str | Path, *, readonly: bool = False):
        self.path = Path(path)
        with store_errors(self.path):  # a damaged file: one line saying how to move it aside
            self._connect(readonly)

    def _connect(self, readonly: bool) -> None:
        if readonly:
            if not self.path.is_file():
                raise DataError(f"no results store at {self.path}")
            uri = f"file:{self.path.resolve()}?mode=ro"
            self._db = sqlite3.connect(uri, uri=True, timeout=30.0)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(self.path, timeout=30.0)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._create()
        self._db.row_factory = sqlite3.Row
        self._warned_keys: set[str] = set()

    @classmethod
    def open(cls, out_dir: str | Path, *, readonly: bool = False) -> ResultStore:
        return cls(Path(out_dir) / STORE_NAME, readonly=readonly)

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._db.close()

    # -- schema --------------------------------------------------------------------------
    def _create(self) -> None:
        cols = ",\n  ".join(f"{n} {t}" for n, t in CONTRACT_COLUMNS + EXTRA_COLUMNS)
        run_cols = ",\n  ".join(f"{n} {t}" for n, t in RUN_COLUMNS)
        with self._db:
            self._db.execute(
                f"CREATE TABLE IF NOT EXISTS results (\n  {cols},\n  UNIQUE(condition_id, enhancer)\n)"
            )
            self._db.execute(f"CREATE TABLE IF NOT EXISTS runs (\n  {run_cols}\n)")
            self._db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)")
            # A store written by an older version may lack newer extra columns: add them.
            have = {r[1] for r in self._db.execute("PRAGMA table_info(results)")}
            for name, typ in EXTRA_COLUMNS:
                if name not in have:
                    self._db.execute(f"ALTER TABLE results ADD COLUMN {name} {typ}")
            if "split" not in have:  # rows from before splits drew from every file and seed
                self._db.execute("UPDATE results SET split = 'all'")
            self._create_ratings()

    def _create_ratings(self) -> None:
        """Table ``ratings`` (inside :meth:`_create`'s transaction), guarded by its layout version."""
        row = self._db.execute("SELECT value FROM meta WHERE key = 'ratings_schema'").fetchone()
        if row is not None and int(row[0]) > RATINGS_SCHEMA_VERSION:
            raise DataError(
                f"the ratings in {self.path} have layout version {row[0]}, newer than this scenesim "
                f"reads ({RATINGS_SCHEMA_VERSION}); upgrade scenesim to add or read ratings"
            )
        cols = ",\n  ".join(f"{n} {t}" for n, t in RATING_COLUMNS)
        self._db.execute(
            f"CREATE TABLE IF NOT EXISTS ratings (\n  {cols},\n  UNIQUE(listener, condition_id, system, scale)\n)"
        )
        self._db.execute(
            "INSERT OR IGNORE INTO meta (key, value) VALUES ('ratings_schema', ?)", (str(RATINGS_SCHEMA_VERSION),)
        )

    @property
    def journal_mode(self) -> str:
        return self._db.execute("PRAGMA journal_mode").fetchone()[0]

    # -- writing -------------------------------------------------------------------------
    def write_rows(self, rows: Iterable[Mapping[str, Any]]) -> int:
        """Insert or replace ``rows`` (one condition's) in a single transaction; returns the count.

        Keys that are not columns are ignored (logged once at debug level); missing
        columns are NULL; ``created_at`` defaults to now.
        """
        rows = list(rows)
        if not rows:
            return 0
        now = utc_now()
        placeholders = ", ".join("?" for _ in COLUMNS)
        updates = ", ".join(f"{c}=excluded.{c}" for c in COLUMNS if c not in ("condition_id", "enhancer"))
        sql = (
            f"INSERT INTO results ({', '.join(COLUMNS)}) VALUES ({placeholders}) "
            f"ON CONFLICT(condition_id, enhancer) DO UPDATE SET {updates}"
        )
        values = []
        for row in rows:
            extra = set(row) - set(COLUMNS)
            new = extra - self._warned_keys
            if new:
                log.debug("results store ignores keys not in the schema: %s", ", ".join(sorted(new)))
                self._warned_keys |= new
            values.append(tuple(_sql_value(row.get(c, now if c == "created_at" else None)) for c in COLUMNS))
        with self._db:
            self._db.executemany(sql, values)
        return len(values)

    def write_rating(self, rating: Mapping[str, Any]) -> None:
        """Insert or replace one rating (keys of :data:`RATING_COLUMNS`; ``rated_at`` defaults
        to now) in its own transaction, so a rating is kept the moment it is given."""
        names = [n for n, _ in RATING_COLUMNS]
        values = tuple(_sql_value(rating.get(n, utc_now() if n == "rated_at" else None)) for n in names)
        keep = ("listener", "condition_id", "system", "scale")
        updates = ", ".join(f"{n}=excluded.{n}" for n in names if n not in keep)
        with store_errors(self.path), self._db:
            self._db.execute(
                f"INSERT INTO ratings ({', '.join(names)}) VALUES ({', '.join('?' for _ in names)}) "
                f"ON CONFLICT(listener, condition_id, system, scale) DO UPDATE SET {updates}",
                values,
            )

    def start_run(
        self,
        *,
        sweep: str,
        source: str,
        config_toml: str,
        options: Mapping[str, Any],
        executor: str,
        workers: int | None,
        scheduler: str | None,
        data_dir: str | None,
    ) -> str:
        """Record a new run (status ``running``); returns its id."""
        run_id = uuid.uuid4().hex[:12]
        with self._db:
            self._db.execute(
                "INSERT INTO runs (run_id, sweep, source, config_toml, options_json, versions_json, "
                "executor, workers, scheduler, data_dir, hostname, started_at, status, "
                "n_rows_written, n_errors) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'running', 0, 0)",
                (
                    run_id,
                    sweep,
                    source,
                    config_toml,
                    json.dumps(dict(options), sort_keys=True, default=str),
                    json.dumps(package_versions(), sort_keys=True),
                    executor,
                    workers,
                    scheduler,
                    data_dir,
                    socket.gethostname(),
                    utc_now(),
                ),
            )
        return run_id

    def mark_abandoned_runs(self) -> int:
        """Mark runs still ``running`` as ``killed``; call only while holding the run lock (then
        no live run can be writing, so these ended without finishing, e.g. ``kill -9``)."""
        with self._db:
            cur = self._db.execute(
                "UPDATE runs SET status='killed', finished_at=? WHERE status='running'", (utc_now(),)
            )
        return cur.rowcount

    def finish_run(self, run_id: str, *, status: str, n_rows_written: int, n_errors: int) -> None:
        with self._db:
            self._db.execute(
                "UPDATE runs SET finished_at=?, status=?, n_rows_written=?, n_errors=? WHERE run_id=?",
                (utc_now(), status, n_rows_written, n_errors, run_id),
            )

    def set_meta(self, key: str, value: str) -> None:
        """Store-wide facts (e.g. the sweep version its rows belong to)."""
        with self._db:
            self._db.execute(
                "INSERT INTO meta (key, value) VALUES (?, ?) ON CONFLICT(key) DO UPDATE SET value=excluded.value",
                (key, value),
            )

    def archive_rows(self) -> int:
        """Move every row of ``results`` to ``results_previous`` (kept, never deleted); returns
        the count.  Starting a new sweep version in the same store goes through here."""
        with self._db:
            self._db.execute("CREATE TABLE IF NOT EXISTS results_previous AS SELECT * FROM results WHERE 0")
            have = {r[1] for r in self._db.execute("PRAGMA table_info(results_previous)")}
            for name, typ in CONTRACT_COLUMNS + EXTRA_COLUMNS:
                if name not in have:
                    self._db.execute(f"ALTER TABLE results_previous ADD COLUMN {name} {typ.split()[0]}")
            cols = ", ".join(COLUMNS)
            n = self._db.execute(f"INSERT INTO results_previous ({cols}) SELECT {cols} FROM results").rowcount
            self._db.execute("DELETE FROM results")
        return n

    # -- reading -------------------------------------------------------------------------
    def get_meta(self, key: str) -> str | None:
        try:
            row = self._db.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        except sqlite3.OperationalError:  # a read-only store from before the meta table
            return None
        return None if row is None else row[0]

    def done_keys(self, *, include_errors: bool = True) -> set[tuple[str, str]]:
        """``{(condition_id, enhancer)}`` already stored (with ``include_errors=False``: status ok only)."""
        sql = "SELECT condition_id, enhancer FROM results"
        if not include_errors:
            sql += " WHERE status = 'ok'"
        return {(r[0], r[1]) for r in self._db.execute(sql)}

    def stored_specs(self) -> dict[tuple[str, str], str | None]:
        """``{(condition_id, enhancer): enhancer_spec JSON}``: lets a rerun notice changed params."""
        return {(r[0], r[1]): r[2] for r in self._db.execute("SELECT condition_id, enhancer, enhancer_spec FROM results")}

    def rows(self, where: str = "", params: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """All rows (optionally filtered by an SQL ``where`` clause) as dicts, in insertion order."""
        sql = "SELECT * FROM results" + (f" WHERE {where}" if where else "") + " ORDER BY rowid"
        with store_errors(self.path):  # pages damaged past the header fail only when read
            return [dict(r) for r in self._db.execute(sql, tuple(params))]

    def count(self) -> int:
        with store_errors(self.path):
            return self._db.execute("SELECT COUNT(*) FROM results").fetchone()[0]

    def ratings(self, listener: str | None = None) -> list[dict[str, Any]]:
        """The listening-test ratings (of one ``listener``, or all), in the order given; a store
        from before the ratings table has none."""
        sql = "SELECT * FROM ratings" + (" WHERE listener = ?" if listener is not None else "") + " ORDER BY rowid"
        try:
            with store_errors(self.path):
                return [dict(r) for r in self._db.execute(sql, () if listener is None else (listener,))]
        except DataError:
            if self._db.execute("SELECT 1 FROM sqlite_master WHERE name = 'ratings'").fetchone() is None:
                return []
            raise

    def runs(self) -> list[dict[str, Any]]:
        with store_errors(self.path):
            return [dict(r) for r in self._db.execute("SELECT * FROM runs ORDER BY started_at")]


def _sql_value(value: Any) -> Any:
    """numpy scalars and bools to Python numbers; containers to JSON text."""
    if value is None or isinstance(value, (str, int, float, bytes)):
        if isinstance(value, float) and value != value:  # NaN: SQLite stores NULL anyway
            return None
        return value
    if hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        return _sql_value(value.item())
    if isinstance(value, (dict, list, tuple)):
        return json.dumps(value, sort_keys=True, default=_json_default)
    return str(value)


def _json_default(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    return str(obj)
