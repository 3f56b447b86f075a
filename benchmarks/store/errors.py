"""The one-line errors of a results store sqlite cannot read or write (every way in: CLI and Python API)."""

from __future__ import annotations

import contextlib
import sqlite3
from pathlib import Path

from scenesim.errors import DataError

__all__ = ["corrupt_store_error", "is_corruption", "store_errors"]


#: sqlite primary result codes (low byte) of a refused write or open: SQLITE_FULL (ENOSPC, EFBIG,
#: EDQUOT), READONLY, IOERR, CANTOPEN, PERM.  The file on disk is intact after these; every other
#: failure (CORRUPT, NOTADB, text that does not decode) means the store itself is damaged.
_WRITE_REFUSED_CODES = {13: "SQLITE_FULL", 8: "SQLITE_READONLY", 10: "SQLITE_IOERR", 14: "SQLITE_CANTOPEN",
                        3: "SQLITE_PERM"}


def is_corruption(exc: sqlite3.DatabaseError) -> bool:
    """False when sqlite reports a refused write or open (the store is intact), else True."""
    code = getattr(exc, "sqlite_errorcode", None)
    if code is not None:
        return (code & 0xFF) not in _WRITE_REFUSED_CODES
    text = str(exc).lower()  # Python < 3.11 has no error codes: sqlite's fixed messages
    return not any(w in text for w in ("disk is full", "readonly", "disk i/o error", "unable to open"))


def corrupt_store_error(store_path: Path, exc: sqlite3.DatabaseError) -> DataError:
    """The one-line error for a results store sqlite cannot read or write: how to move a damaged
    store aside, or -- when a write was refused (disk full, file-size limit, quota, read-only) --
    that the store is intact and how to resume."""
    if not is_corruption(exc):
        return DataError(
            f"could not write the results store {store_path} ({exc}: the disk is full, a file-size limit "
            f"or quota was hit, or the file system is read-only); the store is intact and keeps every "
            f"row written so far. Free space or lift the limit, then rerun the same command to resume"
        )
    return DataError(
        f"the results store {store_path} is corrupt or unreadable ({exc}); nothing was written. "
        f"Move it aside (mv {store_path} {store_path}.corrupt) and rerun to start a new store"
    )


@contextlib.contextmanager
def store_errors(store_path):
    """sqlite's errors inside the block as :func:`corrupt_store_error`'s one line (no sqlite traceback).

    >>> import tempfile
    >>> bad = Path(tempfile.mkdtemp()) / "results.sqlite"
    >>> _ = bad.write_text("not a database")
    >>> try:
    ...     with store_errors(bad):
    ...         sqlite3.connect(bad).execute("SELECT 1 FROM results").fetchall()
    ... except DataError as e:
    ...     print(str(e).split(";")[0].endswith("is corrupt or unreadable (file is not a database)"))
    True
    """
    try:
        yield
    except sqlite3.DatabaseError as exc:
        raise corrupt_store_error(Path(store_path), exc) from None
