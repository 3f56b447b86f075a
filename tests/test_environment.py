"""The constraints file and the version-drift check CI runs on it.

Oracles: a hand-written constraints file whose differences from the (faked) installed set
are known, and ``pyproject.toml``'s own dependency list (every runtime and dev requirement
must be pinned, or a fresh install resolves it freely and the pins stop meaning anything).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.environment import canonical_name, parse_constraints, version_drift

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def _requirement_names(specs):
    names = set()
    for spec in specs:
        if ";" in spec and "python_version < '3.11'" in spec:
            continue  # tomli: only on 3.10, which the constraints (resolved on 3.11) do not cover
        names.add(canonical_name(re.match(r"[A-Za-z0-9._-]+", spec).group(0)))
    return names


def test_every_declared_dependency_is_pinned():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    wanted = _requirement_names(project["dependencies"])
    wanted |= _requirement_names(project["optional-dependencies"]["dev"])
    pins = parse_constraints((ROOT / "constraints.txt").read_text(encoding="utf-8").splitlines())
    missing = sorted(wanted - set(pins))
    assert not missing, f"constraints.txt lacks {missing}: run bash .ci/refresh-constraints"


def test_drift_names_each_differing_and_missing_package():
    pins = {"numpy": "2.4.6", "scipy": "1.17.1", "pesq": "0.0.4"}
    installed = {"numpy": "2.4.6", "scipy": "1.18.0"}
    assert version_drift(pins, installed) == [
        "pesq: not installed, tested 0.0.4",
        "scipy: installed 1.18.0, tested 1.17.1",
    ]
    assert version_drift(pins, {**installed, "scipy": "1.17.1", "pesq": "0.0.4"}) == []


def test_check_command_fails_with_a_clear_message_on_drift(tmp_path):
    # A pin no environment has: the check must exit 1 and name the package and both versions.
    constraints = tmp_path / "constraints.txt"
    constraints.write_text("numpy==0.0.1\n", encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "benchmarks.environment", "--check", str(constraints)],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 1
    assert re.search(r"numpy: installed \S+, tested 0\.0\.1", out.stderr)
    assert "refresh-constraints" in out.stderr and "Traceback" not in out.stderr


def test_check_command_passes_when_versions_match(tmp_path):
    from importlib import metadata

    constraints = tmp_path / "constraints.txt"
    constraints.write_text(f"# tested\nnumpy=={metadata.version('numpy')}\n", encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "benchmarks.environment", "--check", str(constraints)],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert "all 1 pinned" in out.stdout


@pytest.mark.parametrize("name", ["missing.txt"])
def test_check_command_unreadable_file_is_one_line(tmp_path, name):
    out = subprocess.run([sys.executable, "-m", "benchmarks.environment", "--check", str(tmp_path / name)],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "cannot read" in out.stderr
