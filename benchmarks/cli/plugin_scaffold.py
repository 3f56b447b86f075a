"""Write a new, pip-installable enhancer plugin package (``scenesim plugin new NAME --dest DIR``).

The package holds everything the plugin contract asks for (contract.md, "The enhancer
plugin contract"), as a working template to replace with one's own algorithm:

* ``pyproject.toml`` registering the class under the ``scenesim.enhancers`` entry point,
* ``<module>/enhancer.py``: an :class:`enhancers.core.base.Enhancer` with a frozen ``Params``
  (one validated field), ``tags``, batch ``process`` with an exact ``replay``, and
  streaming ``init_state`` / ``process_block``,
* ``tests/test_<module>.py`` running the conformance suite
  (:func:`enhancers.testing.parametrize_with_checks`) and one behaviour test,
* ``README.md`` saying how to install, test and benchmark it.

Example
-------
>>> from pathlib import Path; import tempfile
>>> files = new_plugin("my-gain", Path(tempfile.mkdtemp()) / "plug")
>>> sorted(f.name for f in files)
['README.md', '__init__.py', 'enhancer.py', 'pyproject.toml', 'test_scenesim_my_gain.py']
"""

from __future__ import annotations

import keyword
import re
import string
from pathlib import Path

from scenesim.errors import ParameterError, ScenesimError

__all__ = ["NAME_PATTERN", "module_name", "new_plugin"]

NAME_PATTERN = re.compile(r"^[a-z][a-z0-9]*(-[a-z0-9]+)*$")
"""Registry names a plugin may take: lowercase words of letters and digits joined by '-'."""

_MAX_NAME = 40


def module_name(name: str) -> str:
    """Importable package name for the plugin ``name``: ``"my-gain"`` -> ``"scenesim_my_gain"``."""
    return "scenesim_" + name.replace("-", "_")


def class_name(name: str) -> str:
    """Class name for the plugin ``name``: ``"my-gain"`` -> ``"MyGain"``."""
    return "".join(part.capitalize() for part in name.split("-"))


def _template_globals() -> set[str]:
    """Names the generated modules import (a class of the same name would shadow them)."""
    names = set()
    for template in (_ENHANCER, _TEST, _INIT):
        for m in re.finditer(r"^(?:from \S+ )?import (.+)$", template, flags=re.M):
            names.update(part.split(" as ")[-1].strip() for part in m.group(1).split(","))
    return {n for n in names if n.isidentifier()}


def _check_name(name: str) -> str:
    if not isinstance(name, str) or not NAME_PATTERN.match(name) or len(name) > _MAX_NAME:
        raise ParameterError(
            "NAME", name,
            f"lowercase letters and digits in words joined by '-', starting with a letter, at most {_MAX_NAME} characters (e.g. 'my-denoiser')",
        )
    cls = class_name(name)
    if keyword.iskeyword(cls) or cls in _template_globals():
        raise ParameterError(
            "NAME", name,
            f"a name whose class {cls!r} is no Python keyword and does not shadow a name the "
            f"template imports ({', '.join(sorted(_template_globals()))}); e.g. 'my-{name}'",
        )
    from enhancers.core.registry import available

    if name in available():
        raise ParameterError("NAME", name, "a name no installed enhancer uses (see 'scenesim bench list')")
    return name


def _check_dest(dest: Path) -> Path:
    dest = Path(dest)
    if dest.exists() and not dest.is_dir():
        raise ParameterError("--dest", str(dest), "a new or empty directory (this is a file)")
    if dest.is_dir() and any(dest.iterdir()):
        raise ParameterError("--dest", str(dest), "a new or empty directory (this one is not empty)")
    return dest


def new_plugin(name: str, dest) -> list[Path]:
    """Write the plugin package for the enhancer ``name`` into the new or empty directory ``dest``.

    Returns the files written.  Raises :class:`ParameterError` (one line) for a bad or
    taken name or a non-empty ``dest``, :class:`ScenesimError` if writing fails.
    """
    _check_name(name)
    dest = _check_dest(dest)
    module = module_name(name)
    values = {"name": name, "module": module, "cls": class_name(name), "dist": f"scenesim-{name}"}
    files = {
        dest / "pyproject.toml": _PYPROJECT,
        dest / "README.md": _README,
        dest / module / "__init__.py": _INIT,
        dest / module / "enhancer.py": _ENHANCER,
        dest / "tests" / f"test_{module}.py": _TEST,
    }
    written = []
    try:
        for path, template in files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(string.Template(template).substitute(values), encoding="utf-8")
            written.append(path)
    except OSError as exc:
        raise ScenesimError(f"cannot write the plugin into {dest}: {exc.strerror or exc}") from None
    return written


# -- templates (string.Template: $name, $module, $cls, $dist) ---------------------------------
_PYPROJECT = '''\
[build-system]
requires = ["setuptools>=61"]
build-backend = "setuptools.build_meta"

[project]
name = "$dist"
version = "0.1.0"
description = "The '$name' speech enhancer as a scenesim plugin"
requires-python = ">=3.10"
dependencies = ["scenesim>=0.1", "numpy>=1.24"]

[project.optional-dependencies]
test = ["pytest>=7"]

# scenesim finds the enhancer through this entry point once the package is installed.
[project.entry-points."scenesim.enhancers"]
$name = "$module.enhancer:$cls"

[tool.setuptools]
packages = ["$module"]
'''

_INIT = '''\
"""The '$name' enhancer plugin for scenesim."""

from $module.enhancer import $cls

__all__ = ["$cls"]
'''

_ENHANCER = '''\
"""The '$name' enhancer: a template written by ``scenesim plugin new $name``.

It scales the reference mic by ``gain_db``; replace ``_gain`` (and ``tags`` if your
enhancer takes both mics, delays its output or needs the array geometry) with your
algorithm.  The contract (``enhancers.core.base``): signals are float arrays
``(n_channels, n_samples)``; ``process`` returns a ``Result`` whose ``replay(component)``
applies the same operation to a component of the input (speech or noise alone), which is
how the benchmark measures output SNR; streaming output equals batch output.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from scenesim.validate import check_finite_number


class $cls(Enhancer):
    """Reference mic scaled by ``gain_db`` (the template's placeholder algorithm).

    Example
    -------
    >>> import numpy as np
    >>> $cls(gain_db=-6.0).process(np.ones((1, 4)), 16000).output.round(3)
    array([[0.501, 0.501, 0.501, 0.501]])
    """

    name: ClassVar[str] = "$name"
    version: ClassVar[str] = "1"  # bump when the output changes
    summary: ClassVar[str] = "reference mic scaled by gain_db (plugin template)"

    @dataclass(frozen=True)
    class Params(Params):
        """Every field defaulted and validated; frozen so results record exactly what ran."""

        gain_db: float = 0.0

        def __post_init__(self):
            check_finite_number("gain_db", self.gain_db)

    @property
    def tags(self) -> Tags:
        # channels_in=1: a 2-mic sweep feeds the reference mic.  Declare latency_samples if
        # the output is delayed, needs_geometry=True (and spacing_m / c_mps params) if you
        # use the array geometry, supported_fs if you only run at some rates.
        return Tags(channels_in=1, channels_out=1, streaming=True, latency_samples=0)

    def _gain(self) -> float:
        return 10.0 ** (self.params.gain_db / 20.0)

    # -- batch: x is a validated float64 (1, n) array; never modify it -------------------
    def _process(self, x: np.ndarray, fs: int) -> Result:
        g = self._gain()
        shape = x.shape

        def replay(component) -> np.ndarray:
            # The same (here: fixed) operation on a component of the input.
            return g * check_component(component, shape)

        return Result(output=g * x, trace={"gain": np.full(shape[1], g)}, _replay=replay)

    # -- streaming: (out, state) = step(block, state) -------------------------------------
    def _init_state(self, fs: int):
        return None  # nothing to remember between blocks for a fixed gain

    def _process_block(self, block: np.ndarray, state):
        return self._gain() * block, state
'''

_TEST = '''\
"""The conformance suite every scenesim enhancer passes, plus the plugin's own behaviour.

Run after installing the package (the 'registered' check needs the entry point):
``pip install -e . && python -m pytest tests``.
"""

import numpy as np

from enhancers.testing import parametrize_with_checks
from $module.enhancer import $cls


@parametrize_with_checks([$cls()])
def test_conformance(enhancer, check):
    check(enhancer)


def test_gain_db_scales_the_signal():
    """Oracle: -6 dB is a factor 10 ** (-6 / 20) = 0.501 (tolerance 1e-12)."""
    x = np.random.default_rng(0).standard_normal((1, 1000))
    y = $cls(gain_db=-6.0).process(x, 16000).output
    np.testing.assert_allclose(y, 10 ** (-6 / 20) * x, rtol=1e-12)
'''

_README = '''\
# $dist

The `$name` speech enhancer as a scenesim plugin,
generated by `scenesim plugin new $name`.

```sh
pip install -e .                  # registers '$name' through the scenesim.enhancers entry point
python -m pytest tests            # conformance suite + behaviour tests
scenesim bench list               # '$name' is listed with its version and this package
scenesim enhance in.wav out.wav --enhancer $name --param gain_db=-6
```

Benchmark it with a sweep file naming it, e.g. a copy of the `smoke` preset with
`enhancers = ["$name", "ss", "passthrough"]`: `scenesim bench run my_sweep.toml --out results`.

Edit `$module/enhancer.py`: replace the gain with your algorithm, keep `Params` frozen and
validated, keep `replay` exact (or set `replayable=False` in `tags` for a black box, which
the benchmark then measures by phase inversion), and bump `version` when outputs change.
'''
