"""Issue 15 part 3: a licence compatible with the dependencies, PESQ's terms stated where PESQ
appears, and pyroomacoustics imported only by the cross-checks (lazily)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import tomllib

from benchmarks.cli.bench import PESQ_NOTICE

ROOT = Path(__file__).resolve().parents[1]


def test_licence_file_matches_pyproject():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]["license"]
    assert declared == "MIT"
    assert (ROOT / "LICENSE").read_text("utf-8").startswith("MIT License")


def test_readme_install_section_states_pesq_terms():
    readme = (ROOT / "README.md").read_text("utf-8")
    quick_start = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    assert "MIT" in quick_start and "LICENSE" in quick_start
    assert "C compiler" in quick_start and "source-only" in quick_start
    assert "restricts" in quick_start and "evaluation" in quick_start


def test_bench_list_states_pesq_terms(capsys):
    from benchmarks.cli.main import main

    assert main(["bench", "list"]) == 0
    out = capsys.readouterr().out
    pesq_lines = [line for line in out.splitlines() if "PESQ" in line]
    assert pesq_lines and PESQ_NOTICE in "\n".join(pesq_lines)
    assert "C compiler" in PESQ_NOTICE and "evaluation" in PESQ_NOTICE


def test_importing_the_packages_does_not_import_pyroomacoustics():
    # A fresh interpreter: -X importtime lists every module imported; pyroomacoustics (and its
    # own heavy imports) must appear only when a cross-check runs.
    code = "import scenesim, enhancers, benchmarks, data_recipes, benchmarks.cli.main, benchmarks.run.runner"
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    imported = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines() if "|" in line}
    assert "scenesim" in imported and "benchmarks.run.runner" in imported  # the listing is real
    assert not any(m.split(".")[0] == "pyroomacoustics" for m in imported)
