"""The package layout's imports run one way (issue 15 part 4).

Oracle: every ``import``/``from ... import`` in every module (module level and inside
functions: a lazy import is still a dependency), parsed with ``ast``, against the layer table
below.  A module may import its own layer and the layers beneath it, never one above:

    scenesim core (errors, validate, files, memo, audio) < scenesim.room < scenesim.scene
    < enhancers.core < enhancers.kernels < enhancers.single < enhancers.beam < enhancers.peers
    < enhancers.testing, data_recipes < benchmarks core (excinfo, environment) < benchmarks.metrics
    < benchmarks.store < benchmarks.run < benchmarks.thesis < benchmarks.report < benchmarks.cli
    < benchmarks.perf < benchmarks.studies

Within a floor imports may go sideways, but never round a circle: the second check walks the
whole import graph (lazy imports included) and fails on any cycle.

Package ``__init__`` files that only re-export (``scenesim/__init__.py``, the fixed-path shim
``scenesim/render.py``) are exempt: they are the public surface, not a layer.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("scenesim", "enhancers", "data_recipes", "benchmarks")

# (dotted prefix, rank): the longest matching prefix gives a module's layer.
LAYERS = [
    ("scenesim", 0),
    ("scenesim.room", 1),
    ("scenesim.scene", 2),
    ("enhancers", 3),
    ("enhancers.core", 3.1),
    ("enhancers.kernels", 3.2),
    ("enhancers.single", 3.3),
    ("enhancers.beam", 3.4),
    ("enhancers.peers", 3.5),
    ("enhancers.testing", 3.6),
    ("data_recipes", 3.6),
    ("benchmarks", 4),
    ("benchmarks.metrics", 5),
    ("benchmarks.store", 6),
    ("benchmarks.run", 7),
    ("benchmarks.thesis", 8),
    ("benchmarks.tune", 8.5),
    ("benchmarks.report", 9),
    ("benchmarks.cli", 10),
    ("benchmarks.perf", 11),
    ("benchmarks.studies", 12),
]
EXEMPT = {"scenesim", "scenesim.render", "benchmarks", "enhancers"}  # re-export surfaces


def rank(module: str) -> float:
    best = max((p for p, _ in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return dict(LAYERS)[best]


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(source: str) -> set[str]:
    """Dotted names of the project modules a module's source imports (absolute imports only)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
    return {m for m in found if m.split(".")[0] in PACKAGES}


def _existing(name: str) -> bool:
    path = ROOT / Path(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def all_modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def sources() -> dict[str, str]:
    return {module_name(p): p.read_text(encoding="utf-8") for p in all_modules()}


def violations(modules: dict[str, str]) -> list[str]:
    found = []
    for name, source in sorted(modules.items()):
        if name in EXEMPT:
            continue
        for target in sorted(imports_of(source)):
            if _existing(target) and rank(target) > rank(name):
                found.append(f"{name} (layer {rank(name)}) imports {target} (layer {rank(target)})")
    return found


def test_imports_run_one_way():
    assert violations(sources()) == []


def cycles(modules: dict[str, str]) -> list[list[str]]:
    """Every import cycle among the project's modules (Tarjan's strongly connected components).

    Packages (``__init__``) are left out: ``from scenesim.room import ism`` depends on the module
    ``ism``, and every submodule import runs its package's ``__init__`` anyway.
    """
    packages = {n for n in modules if any(m.startswith(n + ".") for m in modules)}
    graph = {name: sorted(t for t in imports_of(src) if t in modules and t != name and t not in packages)
             for name, src in modules.items() if name not in packages}
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):  # recursion depth is bounded by the module count (a few hundred)
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles():
    assert cycles(sources()) == []


def test_the_cycle_check_sees_a_planted_circle():
    # The circle the move by job removed: the Martin 2001 tracker and the streaming kernels.
    modules = sources()
    modules["enhancers.kernels.stream"] += "\ndef f():\n    import enhancers.single.noise_tracking\n"
    assert ["enhancers.kernels.stream", "enhancers.single.noise_tracking"] in cycles(modules)


@pytest.mark.parametrize(("module", "upward"), [
    ("scenesim.room.shoebox", "from scenesim.scene.compose import Scene"),
    ("enhancers.kernels.frames", "from enhancers.single.ss import SpectralSubtraction"),
    ("enhancers.single.ss", "    from enhancers.beam.eb import ElkoBeamformer"),
    ("enhancers.core.chain", "import enhancers.peers.dfn3"),
    ("benchmarks.run.runner", "    from benchmarks.report.core import write_report"),  # lazy, in a def
    ("benchmarks.metrics.evaluate", "import benchmarks.store.sqlite"),
])
def test_the_layer_check_sees_an_upward_import(module, upward):
    modules = sources()
    body = f"def f():\n{upward}\n" if upward.startswith(" ") else upward + "\n"
    modules[module] += "\n" + body
    assert [v for v in violations(modules) if v.startswith(module + " ")]


@pytest.mark.parametrize("package", ["scenesim/room", "scenesim/scene", "enhancers/core", "enhancers/kernels",
                                     "enhancers/single", "enhancers/beam", "enhancers/peers", "benchmarks/metrics",
                                     "benchmarks/store", "benchmarks/run", "benchmarks/thesis",
                                     "benchmarks/report", "benchmarks/cli", "benchmarks/perf",
                                     "benchmarks/studies"])
def test_each_job_is_a_package(package):
    assert (ROOT / package / "__init__.py").exists() or package == "benchmarks/perf"
    assert list((ROOT / package).glob("*.py"))


def test_no_flat_module_is_left_where_a_package_holds_its_job():
    flat = {p.stem for p in (ROOT / "scenesim").glob("*.py")}
    assert flat <= {"__init__", "errors", "validate", "files", "memo", "audio", "render", "lazy"}
    flat = {p.stem for p in (ROOT / "enhancers").glob("*.py")}
    assert flat <= {"__init__", "testing", "_aliases"}
    flat = {p.stem for p in (ROOT / "benchmarks").glob("*.py")}
    assert flat <= {"__init__", "excinfo", "environment"}


def test_public_imports_named_in_the_readme_and_contract_still_work():
    import benchmarks
    import enhancers
    import scenesim
    from enhancers.testing import check_enhancer
    from scenesim.render import room_rir

    for name in ("ShoeBox", "image_source_rir", "calibrate_room"):
        assert callable(getattr(scenesim, name))
    assert callable(benchmarks.load_results) and callable(enhancers.make)
    assert callable(check_enhancer) and callable(room_rir)


def test_docs_package_table_matches_the_tree():
    # Every subpackage of the tree has a row in the docs' "What lives where" table
    # (docs/guide/development.md), and every row names a folder that exists.
    import re

    table = (ROOT / "docs" / "guide" / "development.md").read_text(encoding="utf-8")
    rows = set(re.findall(r"^\| `((?:scenesim|benchmarks)/[\w/]*)`", table, re.M))
    tree = {f"{p.relative_to(ROOT).as_posix()}/" for pkg in ("scenesim", "benchmarks")
            for p in (ROOT / pkg).iterdir() if p.is_dir() and any(p.glob("*.py"))}
    assert tree <= rows, f"docs/guide/development.md lacks rows for {sorted(tree - rows)}"
    assert all((ROOT / r).is_dir() for r in rows if r.endswith("/")), rows


def _scripts(folder: str) -> list[str]:
    return sorted(p.stem for p in (ROOT / "benchmarks" / folder).glob("*.py") if p.stem != "__init__")


@pytest.mark.parametrize("module", [f"benchmarks.{d}.{s}" for d in ("perf", "studies") for s in _scripts(d)])
def test_every_benchmark_script_imports_against_todays_api(module):
    # A script that no longer runs against today's API fails here rather than on its next user.
    import importlib

    mod = importlib.import_module(module)
    assert mod.__doc__, f"{module} has no docstring saying what it measures"


def test_every_study_has_an_index_line():
    index = (ROOT / "benchmarks" / "studies" / "README.md").read_text(encoding="utf-8")
    assert [s for s in _scripts("studies") if f"`{s}`" not in index] == []
