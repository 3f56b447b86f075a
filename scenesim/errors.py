"""The project's one exception hierarchy.

Every error scenesim raises on purpose derives from :class:`ScenesimError`, so a
caller can catch the whole family.  Bad arguments raise :class:`ParameterError`,
which is also a ``ValueError`` and whose message names the parameter, echoes the
value and says what is allowed, e.g.::

    Parameter absorption=1.7 is invalid: expected a value in (0, 1].

All classes pickle with their arguments (Dask and process pools ship them between
processes), hence the explicit ``__reduce__`` where ``__init__`` takes more than a
message.
"""

from __future__ import annotations

from typing import Any


class ScenesimError(Exception):
    """Root of every error raised deliberately by scenesim, enhancers, data_recipes, benchmarks."""


class ParameterError(ScenesimError, ValueError):
    """A parameter (or input signal) has a value that is not allowed.

    Parameters
    ----------
    name : str
        The parameter's name as the user spelled it (``"absorption"``, ``"x"``, ``"fs"``).
    value : Any
        The offending value; echoed with ``repr`` (arrays are summarised by shape/dtype).
    allowed : str
        What would have been accepted, as a phrase: ``"a value in (0, 1]"``.
    """

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"Parameter {name}={_short_repr(value)} is invalid: expected {allowed}.")

    def __reduce__(self):
        return (type(self), (self.name, self.value, self.allowed))


class ConfigError(ScenesimError, ValueError):
    """A configuration file (sweep TOML) is malformed; the message names the key and the line."""


class DataError(ScenesimError):
    """Audio data is missing, unreadable, empty, too short or silent; the message names the file."""


class PluginError(ScenesimError):
    """An enhancer plugin could not be found or loaded; the message names the package."""


class MetricError(ScenesimError):
    """A metric could not be computed for this signal (e.g. PESQ found no utterance)."""


class ExtraNotInstalled(ScenesimError, ImportError):
    """An optional extra a requested feature needs is not installed; the message is the install line.

    >>> str(ExtraNotInstalled("dnsmos", "DNSMOS"))
    'DNSMOS needs the optional [dnsmos] extra: pip install "scenesim[dnsmos]"'
    """

    def __init__(self, extra: str, feature: str):
        self.extra = extra
        self.feature = feature
        super().__init__(f'{feature} needs the optional [{extra}] extra: pip install "scenesim[{extra}]"')

    def __reduce__(self):
        return (type(self), (self.extra, self.feature))


def _short_repr(value: Any) -> str:
    """``repr`` that keeps arrays and long values readable inside one error line."""
    shape = getattr(value, "shape", None)
    dtype = getattr(value, "dtype", None)
    if shape is not None and dtype is not None:
        return f"<array shape={tuple(shape)} dtype={dtype}>"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
