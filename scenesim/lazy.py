"""Package namespaces whose public names load on first use (PEP 562).

Why: ``import scenesim`` or ``import data_recipes`` used to import every submodule, and through
them scipy.signal (~1.3 s CPU with scipy 1.17); a command that needs one module (``scenesim bench
report``) paid for all of them.  A package lists ``name -> defining module`` and gets back the
module-level ``__getattr__`` and ``__dir__`` that import a module when one of its names is first
asked for.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping


def lazy_exports(package: str, namespace: dict, sources: Mapping[str, str]) -> tuple[Callable, Callable]:
    """``(__getattr__, __dir__)`` for ``package`` whose module globals are ``namespace``.

    >>> ns = {}
    >>> getattr_, dir_ = lazy_exports("pkg", ns, {"sqrt": "math"})
    >>> getattr_("sqrt")(9.0), "sqrt" in ns, "sqrt" in dir_()
    (3.0, True, True)
    """

    def __getattr__(name: str):
        try:
            module = sources[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value  # cached: later lookups do not come back here
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *sources})

    return __getattr__, __dir__
