"""``scenesim plugin new``: the generated package conforms, errors are one line, and end to end it
installs into a fresh virtualenv, passes its own tests, is listed and runs in a smoke sweep."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from benchmarks.cli.main import main
from benchmarks.cli.plugin_scaffold import new_plugin
from enhancers.core import registry
from enhancers.testing import check_enhancer

REPO = Path(__file__).resolve().parents[1]


def test_generated_package_is_complete_and_its_enhancer_conforms(tmp_path, monkeypatch):
    """The files exist, pyproject names the entry point, and the enhancer passes every
    conformance check (registered here in-process, as its entry point would)."""
    files = new_plugin("toy-scaffold", tmp_path / "plug")
    assert {f.relative_to(tmp_path / "plug").as_posix() for f in files} == {
        "pyproject.toml", "README.md", "scenesim_toy_scaffold/__init__.py",
        "scenesim_toy_scaffold/enhancer.py", "tests/test_scenesim_toy_scaffold.py"}
    meta = tomllib.loads((tmp_path / "plug" / "pyproject.toml").read_text())
    assert meta["project"]["entry-points"]["scenesim.enhancers"] == {
        "toy-scaffold": "scenesim_toy_scaffold.enhancer:ToyScaffold"}
    monkeypatch.syspath_prepend(str(tmp_path / "plug"))
    registry.register("toy-scaffold", "scenesim_toy_scaffold.enhancer:ToyScaffold")
    try:
        report = check_enhancer(registry.make("toy-scaffold"))
    finally:
        registry.unregister("toy-scaffold")
        sys.modules.pop("scenesim_toy_scaffold.enhancer", None)
        sys.modules.pop("scenesim_toy_scaffold", None)
    assert set(report.values()) == {"passed"}


@pytest.mark.parametrize(("argv", "message"), [
    (["plugin", "new", "My_Plugin"], "Parameter NAME='My_Plugin' is invalid: expected lowercase letters"),
    (["plugin", "new", "ss"], "Parameter NAME='ss' is invalid: expected a name no installed enhancer uses"),
    (["plugin", "new", "fine-name"], "is invalid: expected a new or empty directory (this one is not empty)"),
])
def test_errors_are_one_line(tmp_path, capsys, argv, message):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.txt").write_text("x")
    assert main([*argv, "--dest", str(tmp_path / "full")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("scenesim: error: ") and message in err
    assert not (tmp_path / "full" / "pyproject.toml").exists()


@pytest.mark.slow
def test_end_to_end_install_test_list_and_smoke_run(tmp_path):
    """Generate; a fresh virtualenv that sees this environment's packages (scenesim, numpy, pytest)
    through a .pth; pip install the plugin (its own build, entry point); its tests pass; it is
    listed by `bench list`; a copy of the smoke preset naming it runs with status ok (~25 s)."""
    assert main(["plugin", "new", "toy-e2e", "--dest", str(tmp_path / "plug")]) == 0
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = str(venv / "bin" / "python")
    site_dir = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                              capture_output=True, text=True, check=True).stdout.strip()
    parent = sysconfig.get_paths()["purelib"]
    Path(site_dir, "_parent_env.pth").write_text(f"import site; site.addsitedir({parent!r})\n")

    def run(*cmd, **kw):
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, **kw)
        assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
        return out.stdout

    run(sys.executable, "-m", "pip", "--python", py, "install", "-q", str(tmp_path / "plug"))
    assert "passed" in run(py, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path / "plug" / "tests"))
    listing = run(py, "-m", "benchmarks.cli.main", "bench", "list")
    assert any(line.split()[:3] == ["toy-e2e", "v1", "scenesim-toy-e2e"] for line in listing.splitlines())

    smoke = (REPO / "benchmarks" / "presets" / "smoke.toml").read_text()
    sweep = (smoke.replace('enhancers = ["eb", "ss", "eb-ss", "passthrough"]', 'enhancers = ["toy-e2e", "passthrough"]')
             .replace('noise = ["babble", "wind"]', 'noise = ["babble"]').replace('name = "smoke"', 'name = "smoke-plugin"'))
    assert '"toy-e2e"' in sweep
    (tmp_path / "sweep.toml").write_text(sweep)
    run(py, "-m", "benchmarks.cli.main", "bench", "run", "sweep.toml", "--out", "out", "--workers", "1")
    with sqlite3.connect(tmp_path / "out" / "results.sqlite") as db:
        rows = db.execute("SELECT status, snr_method FROM results WHERE enhancer = 'toy-e2e'").fetchall()
    assert rows == [("ok", "replay")] * 2


@pytest.mark.parametrize("name", ["gain-", "gain--", "my--gain", "gain-2-", "2gain", "my_gain", "Gain"])
def test_names_with_a_trailing_or_doubled_hyphen_are_refused(name, tmp_path, capsys):
    # A name maps to a module (scenesim_my_gain) and a class (MyGain): "my--gain" and "gain-"
    # would give "scenesim_my__gain" / "Gain" -- one-word pieces only, joined by single hyphens.
    assert main(["plugin", "new", name, "--dest", str(tmp_path / "p")]) == 2
    assert f"Parameter NAME={name!r} is invalid" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize(("name", "module", "cls"), [("gain2", "scenesim_gain2", "Gain2"),
                                                      ("my-gain-3", "scenesim_my_gain_3", "MyGain3")])
def test_good_names_map_to_their_module_and_class(name, module, cls):
    from benchmarks.cli.plugin_scaffold import NAME_PATTERN, class_name, module_name

    assert NAME_PATTERN.match(name) and module_name(name) == module and class_name(name) == cls
