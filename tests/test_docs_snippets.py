"""Every code block a user reads works: README.md and docs/**/*.md.

* A ```` ```python ```` block is executed as written, each in a fresh interpreter whose working
  directory is a new temporary folder (a block cannot lean on another's state, nor leave files in
  the checkout). A block that needs the network, an optional extra or the output of a long run
  starts with the marker line ``# snippet-skip: <reason>`` and is skipped with that reason.
* A ```` ```bash ```` / ```` ```sh ```` block: every ``scenesim ...`` command in it (also after
  ``&&`` or ``;``) is parsed by the command's own argparse parser (``build_parser``), as ``main``
  parses it, without running it: a renamed option or a missing required one fails here.
* A ```` ```toml ```` block is parsed and validated as a sweep (``parse_sweep``).
* The API reference (``docs/reference/api.md``) names every public name of the modules it
  documents, so a new public name cannot be left out of it.
"""

from __future__ import annotations

import importlib
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SKIP_MARKER = "# snippet-skip:"
_FENCE = re.compile(r"^```(\w+)[^\n]*\n(.*?)^```\s*$", re.M | re.S)


def _pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def code_blocks(text: str, languages: tuple[str, ...]) -> list[tuple[int, str]]:
    """``[(line number, code)]`` of the fenced blocks of ``text`` in ``languages``.

    >>> code_blocks("a\\n```python\\nx = 1\\n```\\n```bash\\nls\\n```\\n", ("python",))
    [(2, 'x = 1\\n')]
    """
    return [(text.count("\n", 0, m.start()) + 1, m.group(2)) for m in _FENCE.finditer(text)
            if m.group(1) in languages]


def _blocks(languages: tuple[str, ...]):
    found = []
    for page in _pages():
        if "_build" in page.parts:
            continue
        for line, code in code_blocks(page.read_text(encoding="utf-8"), languages):
            found.append(pytest.param(code, id=f"{page.relative_to(ROOT).as_posix()}:{line}"))
    return found


def scenesim_commands(code: str) -> list[list[str]]:
    """The argument lists of every ``scenesim`` command in a shell block (comments dropped).

    >>> scenesim_commands("pip install x && scenesim bench list  # see\\nscenesim rir \\\\\\n  --dims 1 2 3\\n")
    [['bench', 'list'], ['rir', '--dims', '1', '2', '3']]
    """
    commands = []
    for line in code.replace("\\\n", " ").splitlines():
        segment: list[str] = []
        for token in [*shlex.split(line, comments=True), "&&"]:
            if token in ("&&", ";", "||", "|"):
                if segment[:1] == ["scenesim"]:
                    commands.append(segment[1:])
                segment = []
            else:
                segment.append(token)
    return commands


PYTHON_BLOCKS = _blocks(("python",))
SHELL_BLOCKS = _blocks(("bash", "sh"))
TOML_BLOCKS = _blocks(("toml",))


def test_the_pages_hold_snippets_of_each_kind():
    # The extraction is real: the README and the guide have runnable blocks of every kind.
    assert len(PYTHON_BLOCKS) >= 8 and len(SHELL_BLOCKS) >= 10 and len(TOML_BLOCKS) >= 1
    assert any("README.md" in p.id for p in PYTHON_BLOCKS)


@pytest.mark.parametrize("code", PYTHON_BLOCKS)
def test_python_snippet_runs(code, tmp_path):
    first = code.lstrip().splitlines()[0]
    if first.startswith(SKIP_MARKER):
        pytest.skip(first[len(SKIP_MARKER):].strip())
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, f"snippet failed:\n{code}\n--- stderr ---\n{proc.stderr[-3000:]}"


@pytest.mark.parametrize("code", SHELL_BLOCKS)
def test_shell_snippet_commands_parse(code, capsys):
    from benchmarks.cli.main import _attach_negative_values, build_parser

    parser = build_parser()
    for argv in scenesim_commands(code):
        if "--help" in argv or "-h" in argv:
            continue
        try:
            args = parser.parse_args(_attach_negative_values(argv))
        except SystemExit:
            pytest.fail(f"`scenesim {shlex.join(argv)}` does not parse: {capsys.readouterr().err.strip()}")
        assert callable(args.func), argv


@pytest.mark.parametrize("code", TOML_BLOCKS)
def test_toml_snippet_is_a_valid_sweep(code):
    from benchmarks.run.sweep import parse_sweep

    sweep = parse_sweep(code, source="docs snippet")
    assert sweep.enhancers


API_MODULES = ("scenesim", "enhancers", "enhancers.testing", "benchmarks.metrics.scoring", "benchmarks.tune")


@pytest.mark.parametrize("module", API_MODULES)
def test_api_reference_lists_every_public_name(module):
    page = (ROOT / "docs" / "reference" / "api.md").read_text(encoding="utf-8")
    section = page.split(f".. currentmodule:: {module}\n", 1)
    assert len(section) == 2, f"docs/reference/api.md has no section for {module}"
    listed = set(re.findall(r"^   (\w+)$", section[1].split("```", 1)[0], re.M))
    missing = sorted(set(importlib.import_module(module).__all__) - listed)
    assert not missing, f"docs/reference/api.md lacks {module}.{missing}"
