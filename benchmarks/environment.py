"""Installed versus tested package versions: drift is seen, not suffered.

``constraints.txt`` at the top of the repository pins every distribution the dev install
resolves to (``bash .ci/refresh-constraints`` re-resolves it).  Tests that pin a third-party
library's output (``tests/test_metric_pins.py``) hold at those versions; CI installs with the
file and then runs ``python -m benchmarks.environment --check constraints.txt``, which exits 1
with one line per package whose installed version differs, so a stale pin or a resolver that
ignored the file shows up as a named difference rather than as a failing numeric test.

>>> pins = parse_constraints(["# comment", "numpy==2.4.6", "Foo_Bar == 1.0  # why", ""])
>>> pins
{'numpy': '2.4.6', 'foo-bar': '1.0'}
>>> version_drift(pins, {"numpy": "2.4.6", "foo-bar": "1.1"})
['foo-bar: installed 1.1, tested 1.0']
>>> version_drift({"absent": "1.0"}, {})
['absent: not installed, tested 1.0']
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path

__all__ = ["canonical_name", "installed_versions", "parse_constraints", "version_drift"]

_PIN = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*==\s*([^\s;#]+)")


def canonical_name(name: str) -> str:
    """PEP 503 normalised distribution name.

    >>> canonical_name("Typing_Extensions")
    'typing-extensions'
    """
    return re.sub(r"[-_.]+", "-", name).lower()


def parse_constraints(lines: Iterable[str]) -> dict[str, str]:
    """``{canonical name: version}`` of the ``name==version`` lines (comments and blanks skipped)."""
    pins: dict[str, str] = {}
    for line in lines:
        match = _PIN.match(line)
        if match:
            pins[canonical_name(match.group(1))] = match.group(2)
    return pins


def installed_versions() -> dict[str, str]:
    """``{canonical name: version}`` of every distribution visible to this interpreter."""
    return {canonical_name(d.metadata["Name"]): d.version for d in metadata.distributions()
            if d.metadata["Name"]}


def version_drift(pins: Mapping[str, str], installed: Mapping[str, str]) -> list[str]:
    """One line per pinned package whose installed version differs (or that is missing)."""
    lines = []
    for name, tested in sorted(pins.items()):
        have = installed.get(name)
        if have is None:
            lines.append(f"{name}: not installed, tested {tested}")
        elif have != tested:
            lines.append(f"{name}: installed {have}, tested {tested}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.environment",
        description="Compare installed package versions with a constraints file.")
    parser.add_argument("--check", metavar="CONSTRAINTS", default="constraints.txt",
                        help="the constraints file (default: constraints.txt)")
    args = parser.parse_args(argv)
    path = Path(args.check)
    try:
        pins = parse_constraints(path.read_text(encoding="utf-8").splitlines())
    except OSError as exc:
        print(f"version check: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    drift = version_drift(pins, installed_versions())
    if drift:
        print(f"version check: {len(drift)} installed package(s) differ from {path} "
              "(the tested versions); install with 'pip install -c constraints.txt -e \".[dev]\"' "
              "or refresh the file with 'bash .ci/refresh-constraints' and rerun the tests:",
              file=sys.stderr)
        for line in drift:
            print(f"  {line}", file=sys.stderr)
        return 1
    print(f"version check: all {len(pins)} pinned packages installed at their tested versions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
