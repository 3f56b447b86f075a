"""The search space of ``scenesim tune``: ``--param`` texts read against an enhancer's ``Params``.

``NAME=LO:HI`` searches a number field uniformly in ``[LO, HI]`` (an ``int`` field over the
integers), ``NAME=LO:HI:log`` log-uniformly (``LO > 0``), and ``NAME=a,b,c`` picks one of the
listed values (any field whose values are numbers, text, booleans or ``none``).  Every bound
and choice is checked by building the enhancer's ``Params`` with it, so a value the enhancer
would refuse is refused here, before any trial runs, in one line naming what was typed.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass
from typing import Any

from scenesim.errors import ParameterError

SYNTAX = "NAME=LO:HI, NAME=LO:HI:log or NAME=a,b,c"


@dataclass(frozen=True)
class Dimension:
    """One searched field: a uniform/log-uniform range (``kind`` 'float' or 'int') or a choice.

    >>> Dimension("gain", "float", lo=0.1, hi=1.0, log=True).text
    'gain=0.1:1.0:log'
    """

    name: str
    kind: str  # "float" | "int" | "choice"
    lo: float | int | None = None
    hi: float | int | None = None
    log: bool = False
    choices: tuple = ()

    @property
    def text(self) -> str:
        """The ``--param`` spelling of this dimension (recorded in the provenance)."""
        if self.kind == "choice":
            return f"{self.name}=" + ",".join("none" if c is None else str(c) for c in self.choices)
        return f"{self.name}={self.lo}:{self.hi}" + (":log" if self.log else "")

    def distribution(self):
        """The Optuna distribution of this dimension (for ``study.ask(fixed_distributions)``)."""
        import optuna

        if self.kind == "choice":
            return optuna.distributions.CategoricalDistribution(self.choices)
        if self.kind == "int":
            return optuna.distributions.IntDistribution(int(self.lo), int(self.hi), log=self.log)
        return optuna.distributions.FloatDistribution(float(self.lo), float(self.hi), log=self.log)


def _field_types(params_cls) -> dict[str, Any]:
    """``{field: type}`` with ``X | None`` read as ``X`` (None is only reachable as a choice)."""
    hints = typing.get_type_hints(params_cls)
    out = {}
    for f in dataclasses.fields(params_cls):
        hint = hints.get(f.name, str)
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        out[f.name] = args[0] if typing.get_args(hint) and len(args) == 1 else hint
    return out


def parse_param(text: str, params_cls, *, enhancer: str = "the enhancer") -> Dimension:
    """The :class:`Dimension` a ``--param`` text describes for the dataclass ``params_cls``.

    Raises :class:`ParameterError` naming ``text`` when the syntax is wrong, the field is not
    one of ``params_cls``'s, ``LO > HI``, a log range does not start above 0, or a bound or
    choice is a value the enhancer refuses.

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class P:
    ...     mu: float = 0.1
    ...     taps: int = 8
    >>> parse_param("taps=4:16", P)
    Dimension(name='taps', kind='int', lo=4, hi=16, log=False, choices=())
    >>> parse_param("mu=0.5,0.1", P).choices
    (0.5, 0.1)
    """
    name, eq, value = text.partition("=")
    name = name.strip()
    if not eq or not name or not value.strip():
        raise ParameterError("--param", text, SYNTAX)
    types = _field_types(params_cls)
    if name not in types:
        raise ParameterError("--param", text, f"a field of {enhancer}'s Params: {', '.join(sorted(types))}")
    if ":" in value:
        dim = _range(text, name, value, types[name])
    else:
        dim = Dimension(name, "choice", choices=tuple(_choice(text, name, v, types[name]) for v in value.split(",")))
    for probe in (dim.choices if dim.kind == "choice" else (dim.lo, dim.hi)):
        _check_value(text, params_cls, name, probe)
    return dim


def _number(text: str, word: str, kind: type):
    try:
        value = kind(word.strip())
    except ValueError:
        raise ParameterError("--param", text, f"{SYNTAX} with {kind.__name__} bounds (the field is a {kind.__name__})") from None
    if isinstance(value, float) and not math.isfinite(value):
        raise ParameterError("--param", text, "finite bounds")
    return value


def _range(text: str, name: str, value: str, field_type) -> Dimension:
    parts = value.split(":")
    if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2].strip() != "log"):
        raise ParameterError("--param", text, SYNTAX)
    if field_type not in (int, float):
        raise ParameterError("--param", text, f"NAME=a,b,c for a field of type {getattr(field_type, '__name__', field_type)} (ranges need int or float)")
    lo, hi = (_number(text, p, field_type) for p in parts[:2])
    log = len(parts) == 3
    if lo > hi:
        raise ParameterError("--param", text, f"LO <= HI (got LO={lo} > HI={hi})")
    if log and lo <= 0:
        raise ParameterError("--param", text, f"LO > 0 for a log range (got LO={lo})")
    return Dimension(name, "int" if field_type is int else "float", lo, hi, log)


def _choice(text: str, name: str, word: str, field_type):
    from enhancers.core.base import _parse_value

    word = word.strip()
    if not word:
        raise ParameterError("--param", text, f"{SYNTAX} without empty choices")
    if word.lower() in ("none", "null"):
        return None
    try:
        value = _parse_value(name, word, field_type)
    except ParameterError as exc:
        raise ParameterError("--param", text, f"choices of the field's type: {exc.allowed}") from None
    if not isinstance(value, (bool, int, float, str)):
        raise ParameterError("--param", text, "choices that are numbers, text, booleans or none")
    return value


def _check_value(text: str, params_cls, name: str, value) -> None:
    """Building ``params_cls`` with ``name=value`` must succeed: its own validation is the oracle."""
    try:
        params_cls(**{name: value})
    except (ParameterError, ValueError, TypeError) as exc:
        raise ParameterError("--param", text, f"values the enhancer accepts ({exc})") from None


def parse_space(texts, params_cls, *, enhancer: str = "the enhancer") -> tuple[Dimension, ...]:
    """The dimensions of every ``--param`` text, each field at most once."""
    dims = tuple(parse_param(t, params_cls, enhancer=enhancer) for t in texts)
    if not dims:
        raise ParameterError("--param", None, f"at least one {SYNTAX}")
    seen: set[str] = set()
    for d in dims:
        if d.name in seen:
            raise ParameterError("--param", d.text, f"each field once ({d.name!r} is given twice)")
        seen.add(d.name)
    return dims
