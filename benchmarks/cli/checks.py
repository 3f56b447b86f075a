"""Checks of command-line inputs that turn bad paths and values into one-line errors.

Each raises :class:`~scenesim.errors.ParameterError` (or ``DataError``) naming the option
the user typed and the way out, so ``main`` prints one ``scenesim: error:`` line and exits
2 instead of showing a traceback from deep inside ``os``, ``sqlite3`` or ``scipy``.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import tempfile
from pathlib import Path

from benchmarks.run.lock import LOCK_NAME
from benchmarks.store.errors import corrupt_store_error, is_corruption  # noqa: F401  (re-exported)
from scenesim.errors import DataError, ParameterError
from scenesim.validate import PHYSICAL_RANGES, check_physical

# The lowest rate the CLI accepts: the telephone band.  The built-in test signal is band
# limited to 100 Hz - 4 kHz and the enhancers' filter banks and speech metrics are designed
# for 8 or 16 kHz; below 8 kHz scipy filter design fails or the "speech" is aliased noise.
MIN_FS_HZ, MAX_FS_HZ = PHYSICAL_RANGES["fs"][:2]

# SNRs outside this range are almost certainly typos (one table with the sweep files').
SNR_RANGE_DB = PHYSICAL_RANGES["snr_db"][:2]


def check_cli_fs(option: str, fs: int | None) -> int | None:
    """``fs`` if it is None or an integer >= :data:`MIN_FS_HZ`, else a ParameterError naming ``option``."""
    if fs is not None and not MIN_FS_HZ <= fs <= MAX_FS_HZ:
        raise ParameterError(
            option, fs, f"a sampling rate in [{MIN_FS_HZ}, {MAX_FS_HZ}] Hz (speech band and filters need "
            f">= {MIN_FS_HZ} Hz), e.g. 16000"
        )
    return fs


def check_snr_db(option: str, snr_db: float) -> float:
    """``snr_db`` if it is finite and within :data:`SNR_RANGE_DB`, else a ParameterError naming ``option``."""
    return check_physical(option, snr_db, "snr_db")


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _check_writable_dir(option: str, path: Path, typed=None) -> None:
    """Create and delete a temporary file in ``path``; ``typed`` is what the user gave."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".scenesim-write-test.", dir=path)
    except OSError as exc:
        raise ParameterError(
            option, str(typed or path), f"a writable directory ({_why(exc)}); choose another {option}"
        ) from None
    os.close(fd)
    os.unlink(tmp)


def prepare_out_dir(option: str, path, *, create: bool = True) -> Path:
    """Create the output directory ``path`` (given as ``option``) and check that it is writable.

    Raises ParameterError for an empty path, a path naming an existing file, or a directory
    that cannot be created or written (``/proc/x``, read-only mounts).  With
    ``create=False`` nothing is created: the nearest existing ancestor must be a writable
    directory (for commands that create the directory themselves, and only on success).
    """
    if path is None or str(path).strip() == "":
        raise ParameterError(option, "" if path is None else str(path), "a directory path (not empty)")
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ParameterError(option, str(path), f"a directory, but it is an existing file; choose another {option}")
    if not create:
        ancestor = next(p for p in (path.absolute(), *path.absolute().parents) if p.exists())
        if not ancestor.is_dir():
            raise ParameterError(option, str(path), f"a directory path, but {ancestor} is a file")
        _check_writable_dir(option, ancestor, typed=path)
        return path
    new = [p for p in (path.absolute(), *path.absolute().parents) if not p.exists()]
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(
            option, str(path), f"a directory that can be created ({_why(exc)}); choose another {option}"
        ) from None
    CREATED.extend(new)  # deepest first: removed again if the command is refused (remove_created_dirs)
    _check_writable_dir(option, path)
    return path


CREATED: list[Path] = []
"""Directories :func:`prepare_out_dir` created in this process, deepest first."""


def remove_created_dirs() -> None:
    """Remove the directories this command created that are still empty: a refused command leaves nothing.

    >>> import tempfile
    >>> base = Path(tempfile.mkdtemp())
    >>> out = prepare_out_dir("--out", base / "a" / "b")
    >>> remove_created_dirs(); (base / "a").exists()
    False
    """
    while CREATED:
        p = CREATED.pop(0)
        try:
            lock = p / LOCK_NAME  # a released run lock is no output: the folder counts as empty
            if lock.is_file() and [q.name for q in p.iterdir()] == [LOCK_NAME]:
                lock.unlink()
            p.rmdir()  # only an empty directory: anything written is kept
        except OSError:
            pass


def check_out_file(option: str, path) -> Path:
    """Check that a file can be written at ``path`` (given as ``option``); its folder is created.

    Raises ParameterError for an empty path, an existing directory, or a folder that cannot
    be created or written.
    """
    if path is None or str(path).strip() in ("", "."):
        raise ParameterError(option, "" if path is None else str(path), "a file path (not empty)")
    path = Path(path)
    if path.is_dir():
        raise ParameterError(option, str(path), f"a file name, but it is an existing directory; choose another {option}")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise ParameterError(option, str(path), f"a file in a directory, but {parent} is a file")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(
            option, str(path), f"a file in a directory that can be created ({_why(exc)}); choose another {option}"
        ) from None
    _check_writable_dir(option, parent, typed=path)
    return path


def check_input_file(option: str, path) -> Path:
    """``path`` if it names an existing regular file, else a DataError saying "no such file"."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"no such file: {path} ({option})")
    if path.is_dir():
        raise DataError(f"{path} is a directory; {option} expects an audio file")
    return path


def check_store_readable(store_path) -> None:
    """Read every row of every table of an existing sqlite store, read-only; sqlite's error if it can't.

    Run before a command writes to the store, so that a damaged file (truncated pages,
    garbage, text that is not UTF-8) is reported before anything is added to it.
    """
    store_path = Path(store_path)
    if not store_path.is_file():
        return
    db = sqlite3.connect(f"file:{store_path.resolve()}?mode=ro", uri=True, timeout=30.0)
    try:
        check = db.execute("PRAGMA quick_check").fetchone()
        if check and check[0] != "ok":
            raise sqlite3.DatabaseError(f"integrity check: {check[0]}")
        tables = [r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
        for table in tables:
            for _ in db.execute(f'SELECT * FROM "{table}"'):  # decodes every text value
                pass
    finally:
        db.close()


@contextlib.contextmanager
def options_named(names: dict[str, str]):
    """Re-raise a ParameterError about library parameter ``k`` as one about option ``names[k]``.

    >>> with options_named({"length_s": "--length"}):  # doctest: +SKIP
    ...     image_source_rir(..., length_s=-1)         # "Parameter --length=-1.0 is invalid..."
    """
    try:
        yield
    except ParameterError as exc:
        base, bracket, index = exc.name.partition("[")  # "mics_m[0]" -> "--mic" (first given)
        option = names.get(base)
        if option is None:
            raise
        which = f" #{int(index.rstrip(']')) + 1}" if bracket and index.rstrip("]").isdigit() else ""
        raise ParameterError(option + which, exc.value, exc.allowed) from None
