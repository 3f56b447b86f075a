"""The enhancer plugin contract (contract.md, "The enhancer plugin contract").

An enhancer is a class with

* ``name`` (registry name, e.g. ``"eb"``) and ``version`` (bumped when outputs change),
* a frozen ``Params`` dataclass (subclass of :class:`Params`) whose fields are all
  defaulted and validated in ``__post_init__``,
* ``tags`` (:class:`Tags`: channels in/out, geometry, streaming, latency, fs),
* ``process(x, fs) -> Result`` on a ``(n_channels, n_samples)`` float array, and
* optionally streaming ``init_state(fs)`` / ``process_block(block, state) -> (out, state)``.

Time alignment: ``output[:, n]`` depends on input up to sample ``n``; a filter bank that
needs look-ahead declares it as ``tags.latency_samples`` and its output is delayed by
exactly that much (batch output equals the concatenated streaming output, same length
as the input).  Metrics undo the declared latency before comparing with a reference.

Shadow filtering (algorithms.md section 8): every built-in enhancer is linear once its
adapted quantities are fixed.  ``Result.replay(component)`` applies the *same*
time-varying operation (beta trajectory, gain mask) to a component of the input
(speech-only or noise-only image), so output SNR is measured without guessing.
"""

from __future__ import annotations

import dataclasses
import json
import math
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from scenesim.errors import ParameterError
from scenesim.validate import check_audio_fs, check_signal


@dataclass(frozen=True)
class Params:
    """Base of every enhancer's parameter dataclass: JSON round trip and strict construction.

    Subclasses are ``@dataclass(frozen=True)`` with every field defaulted, and validate in
    ``__post_init__`` with the helpers of :mod:`scenesim.validate` (never ``assert``).
    """

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the fields (JSON-serialisable for numbers, strings, bools, tuples)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]):
        """Build from a mapping; unknown keys raise :class:`ParameterError` naming them.

        Lists (as JSON gives them back) are turned into tuples where the field is a tuple, or may be
        one (a ``tuple | None`` field whose default is None).
        """
        known = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise unknown_parameter(unknown[0], values[unknown[0]], known)
        converted = {}
        for key, value in values.items():
            default = known[key].default
            if isinstance(value, list) and (isinstance(default, tuple) or "tuple" in str(known[key].type)):
                value = tuple(value)
            converted[key] = value
        return cls(**converted)

    @classmethod
    def from_json(cls, text: str):
        return cls.from_dict(json.loads(text))

    @classmethod
    def coerce_strings(cls, values: Mapping[str, str]) -> dict[str, Any]:
        """Convert ``k=v`` strings from a command line to the field types (``--param alpha=0.9``)."""
        hints = typing.get_type_hints(cls)
        known = {f.name for f in dataclasses.fields(cls)}
        out: dict[str, Any] = {}
        for key, text in values.items():
            if key not in known:
                raise unknown_parameter(key, text, known)
            out[key] = _parse_value(key, text, hints.get(key, str))
        return out


def params_with_defaults(params_cls: type, owner: str, defaults: dict, module: str) -> type:
    """A frozen dataclass subclass of ``params_cls`` whose fields named in ``defaults`` default to those
    values (checked by the parent's ``__post_init__``); pickled as ``<module>.<owner>.Params``.

    How a registered variant (``eb-robust-blind``, ``mvdr@1``) states what it changes: the same
    algorithm, other defaults.

    >>> @dataclass(frozen=True)
    ... class P(Params):
    ...     a: int = 1
    ...     b: int = 2
    >>> Q = params_with_defaults(P, "Variant", {"b": 5}, __name__)
    >>> Q(), Q(b=3).b
    (Variant.Params(a=1, b=5), 3)
    """
    types = {f.name: f.type for f in dataclasses.fields(params_cls)}
    namespace = {"__annotations__": {k: types[k] for k in defaults}, "__module__": module,
                 "__qualname__": f"{owner}.Params", **defaults}
    return dataclass(frozen=True)(type("Params", (params_cls,), namespace))


def unknown_parameter(key: str, value, known, owner: str | None = None) -> ParameterError:
    """The error for a parameter ``key`` that is not a field: the fields it could be, or that there are none.

    >>> str(unknown_parameter("x", "1", ()))
    "Parameter x='1' is invalid: expected no parameter: this enhancer has none."
    >>> str(unknown_parameter("alpah", 0.9, ("alpha", "n_sub"), "ss"))
    'Parameter alpah=0.9 is invalid: expected a parameter of ss: one of alpha, n_sub.'
    """
    who = f"a parameter of {owner}: " if owner else ""
    if not known:
        return ParameterError(key, value, f"no parameter: {owner or 'this enhancer'} has none")
    return ParameterError(key, value, f"{who}one of " + ", ".join(sorted(known)))


def _parse_value(key: str, text: str, hint) -> Any:
    origin = typing.get_origin(hint)
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    if origin is typing.Union or (origin is not None and str(origin) == "<class 'types.UnionType'>"):
        if text.lower() in ("none", "null") and len(args) < len(typing.get_args(hint)):
            return None
        hint = args[0] if args else str
    try:
        if hint is bool:
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError(text)
        if hint is int:
            return int(text)
        if hint is float:
            return float(text)
        if hint is str:
            return text
        return json.loads(text)
    except (ValueError, json.JSONDecodeError):
        raise ParameterError(key, text, f"a value of type {getattr(hint, '__name__', hint)}") from None


@dataclass(frozen=True)
class Tags:
    """What an enhancer needs and promises; the runner and the conformance suite read these.

    Attributes
    ----------
    channels_in : int
        Number of input channels ``process`` accepts (exactly).  A 1-channel enhancer in
        a 2-mic sweep is fed the reference mic (channel 0).
    channels_out : int
        Number of output channels.
    needs_geometry : bool
        True if the params carry array geometry (``spacing_m``) the runner must set from the scene.
    streaming : bool
        True if ``init_state`` / ``process_block`` are implemented.
    latency_samples : int
        Output delay in samples relative to the input (see module docstring).
    supported_fs : tuple of int or None
        Sampling rates accepted (Hz); None means any.
    replayable : bool
        True if ``Result.replay`` is exact shadow filtering; False for black-box plugins,
        which the benchmark measures by phase inversion instead.
    """

    channels_in: int
    channels_out: int = 1
    needs_geometry: bool = False
    streaming: bool = False
    latency_samples: int = 0
    supported_fs: tuple[int, ...] | None = None
    replayable: bool = True


@dataclass
class Result:
    """What ``process`` returns.

    Attributes
    ----------
    output : ndarray, shape (n_out, n_samples)
        The enhanced signal, float64, same length as the input.
    trace : dict of str -> ndarray
        Adapted quantities worth plotting or replaying (``"beta"`` per sample, ``"gain"``
        per frame and bin, ...).  Shapes are documented by each enhancer.
    """

    output: np.ndarray
    trace: dict[str, np.ndarray] = field(default_factory=dict)
    _replay: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)

    def replay(self, component) -> np.ndarray:
        """Apply the same time-varying linear operation that produced ``output`` to ``component``.

        ``component`` has the input's shape ``(n_channels_in, n_samples)``; returns
        ``(n_out, n_samples)``.  ``replay(mixture)`` reproduces ``output`` (to 1e-9).
        """
        if self._replay is None:
            raise NotImplementedError("this enhancer's result does not support replay")
        return self._replay(component)


def check_component(component, shape: tuple[int, int]) -> np.ndarray:
    """Validate a ``Result.replay`` component: finite, shaped exactly like the processed input.

    Returns a float64 array (a copy only when the dtype changes); raises
    :class:`ParameterError` naming ``component`` otherwise.
    """
    c = check_signal(component, name="component", n_channels=shape[0], min_samples=0)
    if c.shape != tuple(shape):
        raise ParameterError("component", component, f"shape {tuple(shape)} like the processed input")
    return c


_F64 = np.dtype(np.float64)


def _clean_block(block, n_channels: int) -> bool:
    """True if ``block`` is already what :func:`check_signal` returns: a finite float64 ``(n_channels, n)`` array.

    The per-block fast path of ``process_block`` (``check_signal`` costs ~10 us, a 10 ms block's
    processing ~20 us): a finite sum of squares implies every sample is finite (a NaN or Inf makes
    it NaN or Inf); anything else -- including a sum that overflows -- goes through ``check_signal``.
    ``np.vdot`` (BLAS) raises no floating-point warnings on the way.
    """
    return (type(block) is np.ndarray and block.dtype == _F64 and block.ndim == 2
            and block.shape[0] == n_channels and math.isfinite(np.vdot(block, block)))


class Enhancer:
    """Base class for enhancers; subclasses set ``name``, ``version``, ``Params`` and implement
    ``tags`` and ``_process`` (and ``_init_state`` / ``_process_block`` when streaming).

    ``process`` and ``process_block`` validate their input here, once, so every plugin
    gets the same clear errors; subclasses receive a float64 ``(n_channels, n)`` array
    they must not modify.
    """

    name: ClassVar[str] = ""
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = ""
    Params: ClassVar[type[Params]] = Params

    def __init__(self, params: Params | None = None, **overrides: Any):
        known = {f.name for f in dataclasses.fields(self.Params)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            allowed = ", ".join(sorted(known)) or "no parameters"
            raise ParameterError(unknown[0], overrides[unknown[0]], f"one of {allowed}")
        if params is None:
            params = self.Params(**overrides)
        elif overrides:
            params = dataclasses.replace(params, **overrides)
        if not isinstance(params, self.Params):
            raise ParameterError("params", params, f"an instance of {self.Params.__qualname__}")
        self._params = params

    # -- description -----------------------------------------------------------------
    @property
    def params(self) -> Params:
        return self._params

    @property
    def tags(self) -> Tags:  # pragma: no cover - every enhancer overrides
        raise NotImplementedError

    @property
    def spec(self) -> dict[str, Any]:
        """``{"name", "version", "params"}``: what a results row records about this enhancer."""
        return {"name": self.name, "version": self.version, "params": self._params.to_dict()}

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._params.to_dict().items())
        return f"{type(self).__name__}({fields})"

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and self._params == other._params

    def __hash__(self) -> int:
        return hash((type(self), self._params))

    # -- batch -----------------------------------------------------------------------
    def process(self, x, fs) -> Result:
        """Enhance ``x`` (``(channels_in, n_samples)``, any real dtype) sampled at ``fs`` Hz."""
        x, fs = self.check_input(x, fs)
        return self._process(x, fs)

    def _process(self, x: np.ndarray, fs: int) -> Result:  # pragma: no cover
        raise NotImplementedError

    # -- streaming -------------------------------------------------------------------
    def init_state(self, fs) -> Any:
        """Fresh state for a stream at ``fs`` Hz; independent streams need independent states."""
        if not self.tags.streaming:
            raise NotImplementedError(f"enhancer {self.name!r} does not stream")
        fs = check_audio_fs(fs, supported=self.tags.supported_fs)
        return self._init_state(fs)

    def process_block(self, block, state) -> tuple[np.ndarray, Any]:
        """Process one block ``(channels_in, n_block)``; returns ``(out (n_out, n_block), new_state)``.

        The passed ``state`` may be updated in place or replaced; always use the returned one.
        """
        tags = self.tags
        if not tags.streaming:
            raise NotImplementedError(f"enhancer {self.name!r} does not stream")
        if not _clean_block(block, tags.channels_in):
            block = check_signal(block, name="block", n_channels=tags.channels_in, min_samples=0)
        return self._process_block(block, state)

    def _init_state(self, fs: int) -> Any:  # pragma: no cover
        raise NotImplementedError

    def _process_block(self, block: np.ndarray, state: Any):  # pragma: no cover
        raise NotImplementedError

    # -- helpers ---------------------------------------------------------------------
    def check_input(self, x, fs) -> tuple[np.ndarray, int]:
        """Validate ``x`` and ``fs`` against ``tags``; returns ``(float64 array, int fs)``."""
        tags = self.tags
        fs = check_audio_fs(fs, supported=tags.supported_fs)
        x = check_signal(x, name="x", n_channels=tags.channels_in)
        return x, fs
