"""Third-party plugins through the ``scenesim.enhancers`` entry-point group.

Each test builds REAL distributions in ``tmp_path``: a module plus a ``*.dist-info``
directory (METADATA + entry_points.txt) on ``sys.path``, which is exactly what
``importlib.metadata`` finds for an installed package.
"""

from __future__ import annotations

import sys
import textwrap
from importlib import metadata

import numpy as np
import pytest

from enhancers.core import registry
from enhancers.core.registry import available, describe, make
from enhancers.testing import check_enhancer
from scenesim.errors import PluginError

PLUGIN_CODE = '''
from dataclasses import dataclass
import numpy as np
from enhancers.core.base import Enhancer, Params, Result, Tags
from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_signal

class Gain(Enhancer):
    """Reference mic times a gain (a minimal third-party enhancer)."""
    name = "myplug"
    version = "3"
    summary = "third-party gain"

    @dataclass(frozen=True)
    class Params(Params):
        gain: float = 0.5
        def __post_init__(self):
            check_finite_number("gain", self.gain)

    @property
    def tags(self):
        return Tags(channels_in=2, channels_out=1, streaming=True)

    def _process(self, x, fs):
        g = self.params.gain

        def replay(c):
            c = check_signal(c, name="component", n_channels=2)
            if c.shape != x.shape:
                raise ParameterError("component", c, f"shape {x.shape}")
            return g * c[0:1]

        return Result(output=g * x[0:1], _replay=replay)

    def _init_state(self, fs):
        return None

    def _process_block(self, block, state):
        return self.params.gain * block[0:1], state
'''


def _write_distribution(root, dist: str, module: str, code: str, entry_points: dict[str, str]):
    (root / f"{module}.py").write_text(textwrap.dedent(code))
    info = root / f"{dist}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entry_points.items())
    (info / "entry_points.txt").write_text(f"[scenesim.enhancers]\n{lines}")


@pytest.fixture
def plugin_path(tmp_path, monkeypatch):
    """Installs three distributions: a working one, a broken one, one clashing with a built-in."""
    _write_distribution(tmp_path, "myplug-dist", "myplug", PLUGIN_CODE, {"myplug": "myplug:Gain"})
    _write_distribution(
        tmp_path, "brokenplug-dist", "brokenplug", "import not_a_real_module_xyz\n",
        {"brokenplug": "brokenplug:Thing"},
    )
    _write_distribution(tmp_path, "clashplug", "clashplug", "", {"das": "clashplug:Das"})
    _write_distribution(
        tmp_path, "passplug", "passplug",
        "from enhancers.beam.baselines import Passthrough\n"
        "class Passthrough2(Passthrough):\n    version = '2'\n",
        {"passthrough@2": "passplug:Passthrough2"},
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    registry.reload_plugins()
    yield tmp_path
    monkeypatch.undo()
    for mod in ("myplug", "brokenplug", "clashplug", "passplug"):
        sys.modules.pop(mod, None)
    registry.reload_plugins()


def test_distribution_is_visible_to_importlib_metadata(plugin_path):
    eps = metadata.entry_points(group="scenesim.enhancers")
    assert {"myplug", "brokenplug", "das"} <= {ep.name for ep in eps}


def test_plugin_listed_made_and_conformant(plugin_path):
    assert "myplug" in available()
    e = make("myplug", gain=0.25)
    x = np.ones((2, 10))
    np.testing.assert_array_equal(e.process(x, 16000).output, 0.25 * x[0:1])
    assert make("myplug@3").params.gain == 0.5
    report = check_enhancer(make("myplug"))
    assert set(report.values()) == {"passed"}
    row = next(r for r in describe() if r["name"] == "myplug")
    assert (row["version"], row["source"], row["summary"]) == ("3", "myplug-dist", "third-party gain")


def test_broken_plugin_names_its_package_and_error(plugin_path):
    assert "brokenplug" in available()  # still listed: the failure is reported when asked for
    with pytest.raises(PluginError, match="brokenplug-dist.*No module named 'not_a_real_module_xyz'"):
        make("brokenplug")
    row = next(r for r in describe() if r["name"] == "brokenplug")
    assert row["summary"].startswith("ERROR:") and "brokenplug-dist" in row["summary"]
    # The built-ins are unaffected.
    assert make("passthrough").name == "passthrough"


def test_plugin_cannot_shadow_builtin(plugin_path):
    assert make("das").__module__ == "enhancers.beam.baselines"
    assert "das[clashplug]" in available()
    with pytest.raises(PluginError, match="clashplug.*already registered"):
        make("das[clashplug]")


def test_plugins_gone_after_uninstall(plugin_path, monkeypatch):
    monkeypatch.undo()
    registry.reload_plugins()
    assert "myplug" not in available()


def test_plugin_adds_a_version_of_a_builtin_name(plugin_path):
    # Entry point "passthrough@2": the bare name now gives the latest version.
    assert make("passthrough").version == "2"
    assert type(make("passthrough")).__module__ == "passplug"
    assert make("passthrough@1").__module__ == "enhancers.beam.baselines"
    rows = [r for r in describe() if r["name"] == "passthrough"]
    assert sorted((r["version"], r["source"]) for r in rows) == [("1", "scenesim"), ("2", "passplug")]
