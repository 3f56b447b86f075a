"""The thesis search's inputs, checked before any work: each bad value is one ParameterError naming
what was typed and what is allowed (``scenesim thesis`` and ``python -m benchmarks.thesis.search``).

>>> check_duration("8")
8.0
>>> parse_aliases(["babble=cafe"], ("cafe", "wind"), data="d")
{'babble': 'cafe'}
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from benchmarks.thesis.reference import THESIS_NOISES
from scenesim.errors import ParameterError

DURATION_RANGE_S = (1.0, 60.0)
"""Seconds of speech per cell: PESQ needs >= 1 s; above a minute the 54 cells x readings cost hours."""
MAX_SEED = 1_000_000
"""Largest ``--seed`` (seeds index utterances and noise segments; a practical bound)."""


def check_duration(text, option: str = "--duration") -> float:
    """``text`` as seconds in :data:`DURATION_RANGE_S`."""
    lo, hi = DURATION_RANGE_S
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ParameterError(option, text, f"seconds, a number in [{lo:g}, {hi:g}]") from None
    if not math.isfinite(value) or not lo <= value <= hi:
        raise ParameterError(option, text, f"seconds in [{lo:g}, {hi:g}]")
    return value


def check_count(text, option: str, lo: int, hi: int) -> int:
    """``text`` as an integer in ``[lo, hi]``.

    >>> check_count("3", "--seeds", 2, 10)
    3
    """
    try:
        value = int(str(text).strip())
    except ValueError:
        raise ParameterError(option, text, f"an integer in [{lo}, {hi}]") from None
    if not lo <= value <= hi:
        raise ParameterError(option, text, f"an integer in [{lo}, {hi}]")
    return value


def parse_aliases(items: Sequence[str], available: Sequence[str], *, data: str) -> dict[str, str]:
    """``NOISE=TYPE`` items as ``{thesis noise: noise type}``.

    ``NOISE`` must be one of the thesis' noises; ``TYPE`` one of ``available``, the types of the
    data (``data`` names it in the message).
    """
    out = {}
    for item in items:
        name, sep, target = str(item).partition("=")
        name, target = name.strip(), target.strip()
        if not sep or not name or not target:
            raise ParameterError("--alias", item, "NOISE=TYPE, e.g. babble=cafe")
        if name not in THESIS_NOISES:
            raise ParameterError("--alias", item, f"NOISE one of the thesis' noises {', '.join(THESIS_NOISES)}")
        if target not in available:
            raise ParameterError("--alias", item, f"TYPE one of the noise types of {data}: {', '.join(available) or 'none'}")
        out[name] = target
    return out


def open_checked(data_dir, aliases: Sequence[str]) -> dict[str, str]:
    """Open the data (``data_dir``: an explicit directory must hold speech) and parse ``aliases``
    against its noise types: the directory's own files when one is given (a type it lacks would be
    synthesized, so an alias to it is refused), else the built-in types."""
    from data_recipes import open_data

    ds = open_data(data_dir, require_speech=data_dir is not None)
    available = ds.local_noise_types if data_dir is not None else ds.noise_types()
    return parse_aliases(aliases, tuple(available), data=str(data_dir) if data_dir else "the built-in data")
