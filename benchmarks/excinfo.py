"""One-line descriptions of exceptions for result rows and messages (one copy for the runner and evaluate)."""

from __future__ import annotations

import traceback
from pathlib import Path


def exc_text(exc: BaseException) -> str:
    """``"Type: message (at file.py:line in function)"``: the type, message and innermost frame.

    >>> try:
    ...     1 / 0
    ... except ZeroDivisionError as e:
    ...     exc_text(e).split(" (at ")[0]
    'ZeroDivisionError: division by zero'
    """
    text = f"{type(exc).__name__}: {exc}"
    frames = traceback.extract_tb(exc.__traceback__)
    if frames:
        f = frames[-1]
        text += f" (at {Path(f.filename).name}:{f.lineno} in {f.name})"
    return text
