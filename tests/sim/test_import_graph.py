"""The sim package's import graph, with the families' sim parts: a ground floor that imports
nothing above it, no cycles, and every module importable on its own in a fresh interpreter."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import manigraph_blocks.sim
import manigraph_dishwasher.sim
import manigraph_sim

PACKAGE = Path(manigraph_sim.__file__).parent
#: The sim and the families' sim parts, each with the folder its dotted names start from.
ROOTS = [
    (PACKAGE, PACKAGE.parent),
    *(
        (Path(part.__file__).parent, Path(part.__file__).parents[2])
        for part in (manigraph_blocks.sim, manigraph_dishwasher.sim)
    ),
]
#: Modules that need SAPIEN or a renderer to import; still checked by the static graph.
HEAVY = {"manigraph_sim.physics.video", "manigraph_blocks.sim.maniskill_env"}


def module_name(path: Path, top: Path) -> str:
    parts = path.relative_to(top).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p, top): p for root, top in ROOTS for p in sorted(root.rglob("*.py"))}


def sim_imports(path: Path) -> set[str]:
    """The sim modules ``path`` imports (at any depth, type-checking ones too)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        found |= {n for n in names if n in MODULES}
    return found


def test_world_model_imports_no_other_sim_module() -> None:
    assert sim_imports(MODULES["manigraph_sim.world_model"]) == set()


def test_no_import_cycle_in_the_sim_package() -> None:
    graph = {name: sim_imports(path) - {name} for name, path in MODULES.items()}
    # a package's __init__ importing its own modules is how registration works, not a cycle
    for name in graph:
        graph[name] = {d for d in graph[name] if not name.startswith(d + ".")}
    state: dict[str, int] = {}

    def visit(name: str, trail: list[str]) -> None:
        state[name] = 1
        for dep in sorted(graph[name]):
            if state.get(dep) == 1:
                cycle = [*trail[trail.index(dep) :], dep] if dep in trail else [name, dep]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if dep not in state:
                visit(dep, [*trail, dep])
        state[name] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


#: In one child process: forget every sim module, import one, repeat; so each is imported
#: first, as in a fresh interpreter (third-party imports stay cached: fast).
FIRST_IMPORT_OF_EACH = """
import importlib, sys
ours = {"manigraph_sim", "manigraph_blocks", "manigraph_dishwasher"}
for module in sys.argv[1:]:
    for name in [n for n in sys.modules if n.split(".")[0] in ours]:
        del sys.modules[name]
    importlib.import_module(module)
"""


def test_each_module_imports_first_on_its_own() -> None:
    modules = sorted(set(MODULES) - HEAVY)
    result = subprocess.run(
        [sys.executable, "-c", FIRST_IMPORT_OF_EACH, *modules],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-2000:]
