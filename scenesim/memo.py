"""A memoiser for deterministic arrays, keyed by a stable hash of what they depend on.

:func:`cached_array` memoises ``compute()`` under a key from :func:`array_key` (or
:func:`stable_hash`) -- the babble bank, the bias-compensation tables, room impulse
responses (:mod:`scenesim.room.cache` builds its ISM cache on it).  The key is the sha256 of a
canonical JSON document (sorted keys, floats by their shortest exact ``repr``, tuples as
lists) of every parameter plus a format/version tag -- so it is stable across processes
and runs (no Python ``hash()``); see style.md lesson 12.

Two levels:

* memory: a bounded LRU (:data:`MEMORY_ITEMS` entries) shared by the process;
* disk (optional): ``<dir>/<key>.npy`` in ``cache_dir`` or ``$SCENESIM_CACHE``.  Files are
  written to a temporary file in the same directory and renamed with ``os.replace``
  (atomic on POSIX and Windows), so a crash or a concurrent writer never leaves a torn
  file.  An unreadable file is treated as a miss and rewritten.

Callers get a fresh copy each time, so nothing they do can corrupt the cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import tempfile
import threading
import warnings
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path

import numpy as np

from scenesim.errors import ParameterError

CACHE_FORMAT_ARRAY = "scenesim-array-v1"
"""Format tag of every :func:`array_key` (bump to invalidate all generic cached arrays)."""

MEMORY_ITEMS = 128
"""Maximum number of arrays (RIRs and others) kept in memory (least recently used dropped first)."""

ENV_VAR = "SCENESIM_CACHE"

_lock = threading.Lock()
_memory: OrderedDict[str, np.ndarray] = OrderedDict()


def canonical(value):
    """JSON-ready canonical form: dataclasses by init fields (plus ``__type__``), arrays/tuples as lists."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {
            f.name: canonical(getattr(value, f.name)) for f in dataclasses.fields(value) if f.init
        }
        out["__type__"] = type(value).__name__
        alpha = getattr(value, "wall_absorption", None)
        if alpha is not None:  # rooms: the absorption actually used (rt60-derived included)
            out["wall_absorption"] = canonical(np.asarray(alpha))
        return out
    if isinstance(value, dict):
        return {str(k): canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if isinstance(value, np.ndarray):
        return [canonical(v) for v in value.tolist()]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            return repr(v)
        # Integral floats and ints hash alike (45 == 45.0 for a position); json writes
        # other floats with repr, the shortest exact round trip, so the text is stable.
        return int(v) if v.is_integer() and abs(v) < 2**53 else v
    if value is None or isinstance(value, str):
        return value
    raise ParameterError("value", value, "numbers, strings, sequences, dicts or dataclasses")


def stable_hash(value) -> str:
    """sha256 hex digest of the canonical JSON of ``value`` (stable across processes)."""
    text = json.dumps(canonical(value), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def user_cache_dir() -> Path:
    """The per-user cache directory: ``$XDG_CACHE_HOME/scenesim``, else ``~/.cache/scenesim``.

    >>> user_cache_dir().name
    'scenesim'
    """
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "scenesim"


def _cache_dir(cache_dir, *, persistent: bool = False) -> Path | None:
    if cache_dir is None:
        env = os.environ.get(ENV_VAR)
        if env is None and persistent:
            return user_cache_dir()
        cache_dir = env or None
    return None if cache_dir is None else Path(cache_dir)


def _remember(key: str, value: np.ndarray) -> None:
    with _lock:
        _memory[key] = value
        _memory.move_to_end(key)
        while len(_memory) > MEMORY_ITEMS:
            _memory.popitem(last=False)


def _save_atomic(path: Path, value: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.save(fh, value, allow_pickle=False)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def array_key(kind: str, version, **params) -> str:
    """The cache key of one array: :func:`stable_hash` of ``kind``, ``version`` and ``params``.

    ``kind`` names the quantity (e.g. ``"babble-bank"``) and ``version`` is the producer's
    version constant: bump it when the computation's output changes, so that stale disk
    files never match.  :data:`CACHE_FORMAT_ARRAY` is included as well.
    """
    return stable_hash({"format": CACHE_FORMAT_ARRAY, "kind": kind, "version": version, "params": params})


def cached_array(key: str, compute: Callable[[], np.ndarray], *, cache_dir=None, persistent: bool = False) -> np.ndarray:
    """``compute()`` memoised under ``key``; returns a fresh copy.

    Looks ``key`` up in the in-memory LRU, then in ``<dir>/<key>.npy`` (``cache_dir``, else
    ``$SCENESIM_CACHE``; no disk level when both are unset or empty), and only then calls
    ``compute()``, whose result is stored in both levels (the file written atomically).
    An unreadable or truncated file is a miss: it is recomputed and rewritten.  A directory
    that cannot be written (read-only, full) gives a ``RuntimeWarning``, not an error.

    Parameters
    ----------
    key : str
        A :func:`stable_hash` of a canonical description of everything the array depends
        on, a format/version string included (see :func:`array_key`); used as a file name.
    compute : callable () -> ndarray
        Called on a miss; its result is stored as a read-only float/int array.
    cache_dir : path, optional
        Disk cache directory; default ``$SCENESIM_CACHE``.
    persistent : bool
        For arrays worth keeping per machine (calibrated rooms: seconds each): with
        ``$SCENESIM_CACHE`` unset, use :func:`user_cache_dir` rather than no disk level
        (``SCENESIM_CACHE=`` empty still disables the disk).

    Returns
    -------
    ndarray
        A writable copy of the cached array (same dtype and shape as ``compute()`` gave).
    """
    if not isinstance(key, str) or not key or any(c in key for c in "/\\:. "):
        raise ParameterError("key", key, "a non-empty file-name-safe string (a stable_hash digest)")
    with _lock:
        hit = _memory.get(key)
        if hit is not None:
            _memory.move_to_end(key)
            return hit.copy()
    directory = _cache_dir(cache_dir, persistent=persistent)
    path = None if directory is None else directory / f"{key}.npy"
    if path is not None and path.is_file():
        try:
            value = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError):
            value = None  # unreadable: recompute and overwrite below
        if value is not None:
            value.setflags(write=False)
            _remember(key, value)
            return value.copy()
    value = np.array(compute())  # an owned copy: the caller's array may change later
    value.setflags(write=False)
    _remember(key, value)
    if path is not None:
        try:
            _save_atomic(path, value)
        except OSError as exc:  # read-only or full disk: the cache is an optimisation, go on
            warnings.warn(f"scenesim: cannot write the disk cache in {directory} ({exc.strerror or exc}); "
                          "continuing with the memory cache only", RuntimeWarning, stacklevel=2)
    return value.copy()


def clear_memory_cache() -> None:
    """Forget every array held in memory (disk files are left alone)."""
    with _lock:
        _memory.clear()


def memory_cache_size() -> int:
    """Number of arrays currently held in memory."""
    with _lock:
        return len(_memory)
