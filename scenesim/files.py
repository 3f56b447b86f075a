"""Writing result files: atomically, readable as the umask says, JSON without NaN.

``tempfile.mkstemp`` creates files with mode 0600 whatever the umask; a file moved into
place from it would stay private.  :func:`chmod_as_umask` gives it the mode a plain
``open(path, "w")`` would have had.  JSON has no NaN or Infinity: :func:`to_json` writes
non-finite floats as ``null`` and refuses anything else that is not JSON.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np


def umask_file_mode() -> int:
    """The mode ``open(path, "w")`` gives a new file: ``0o666`` minus the process umask."""
    mask = os.umask(0o022)  # reading the umask means setting it; put it straight back
    os.umask(mask)
    return 0o666 & ~mask


def chmod_as_umask(path) -> None:
    """Give ``path`` the permissions a newly opened file would get under the current umask."""
    os.chmod(path, umask_file_mode())


def json_safe(value):
    """``value`` with NaN/Inf floats replaced by None and numpy scalars/arrays made plain Python.

    >>> json_safe({"a": float("nan"), "b": [1.0, float("inf")]})
    {'a': None, 'b': [1.0, None]}
    """
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def to_json(value, **kwargs) -> str:
    """``json.dumps`` of :func:`json_safe` ``(value)``; ``allow_nan=False`` so nothing invalid slips out."""
    return json.dumps(json_safe(value), allow_nan=False, **kwargs)


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file and ``os.replace`` (mode as the umask says)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        chmod_as_umask(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_json_atomic(path, data) -> Path:
    """Write ``data`` as indented, key-sorted, valid JSON (NaN -> null) atomically to ``path``."""
    return write_text_atomic(path, to_json(data, indent=2, sort_keys=True) + "\n")
