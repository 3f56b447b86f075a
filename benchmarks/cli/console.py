"""How the CLI talks on stderr: ``scenesim: warning:`` lines instead of Python's warning format.

Python prints a :class:`UserWarning` as ``/path/to/module.py:123: UserWarning: text`` plus
the source line -- noise for a command-line user.  :func:`cli_warnings` routes every
warning raised while a command runs to one ``scenesim: warning: text`` line each, printed
once per distinct text.
"""

from __future__ import annotations

import contextlib
import sys
import warnings
from collections.abc import Iterator


def warning_line(message) -> str:
    """The console form of a warning's text: ``scenesim: warning: <first line>``."""
    text = str(message).strip()
    for prefix in ("scenesim: ", "scenesim "):  # some library warnings already name us
        if text.startswith(prefix):
            text = text[len(prefix):]
    return f"scenesim: warning: {text}"


@contextlib.contextmanager
def cli_warnings(stream=None) -> Iterator[None]:
    """Within the block, print warnings as ``scenesim: warning:`` lines (each text once)."""
    seen: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = warning_line(message)
        if text not in seen:
            seen.add(text)
            print(text, file=stream or sys.stderr)

    with warnings.catch_warnings():
        warnings.simplefilter("default")
        old = warnings.showwarning
        warnings.showwarning = show
        try:
            yield
        finally:
            warnings.showwarning = old
