"""The family boundary: no module of the services, ``shared/``, ``tools/``, ``lab/`` or
``training/`` imports a task-family package or names one of its modules; they reach families
only through their ground-floor registries (docs/families.md). Read with ``ast``, so an
import inside a function or under ``TYPE_CHECKING`` counts, and so does a
``"module:attribute"`` string."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import manigraph_sim
from manigraph_shared.family_packages import family_entry_points

REPO = Path(__file__).resolve().parents[2]
#: What must not know a family: every package but the families' own and the tests.
GENERIC = [REPO / "services", REPO / "shared", REPO / "tools", REPO / "lab", REPO / "training"]


def family_packages() -> set[str]:
    """The import names of every family package: those the ``manigraph.families`` entry
    points load from, and every package folder under ``families/`` (declared or not)."""
    declared = {entry.module.split(".")[0] for entry in family_entry_points()}
    folders = {init.parent.name for init in REPO.glob("families/*/*/__init__.py")}
    return declared | folders


def family_references(path: Path, packages: set[str]) -> list[str]:
    """``path:line: name`` for each import of a module of ``packages`` in ``path``, and each
    string that is such a module's name (``"pkg.module"`` or ``"pkg.module:attribute"``)."""
    named = re.compile(rf"({'|'.join(map(re.escape, sorted(packages)))})(\.\w+)*(:\w+)?")
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            names = [node.value] if named.fullmatch(node.value) else []
        found += [
            f"{path}:{node.lineno}: {name}"  # type: ignore[attr-defined]
            for name in names
            if name.split(".")[0].split(":")[0] in packages
        ]
    return found


def test_the_families_are_found_by_their_entry_points() -> None:
    packages = family_packages()
    assert {"manigraph_blocks", "manigraph_dishwasher"} <= packages
    # every package folder under families/ declares itself (the registries see only those)
    assert {entry.module.split(".")[0] for entry in family_entry_points()} == packages


def test_no_service_shared_tools_lab_or_training_module_imports_or_names_a_family() -> None:
    packages = family_packages()
    modules = sorted(p for root in GENERIC for p in root.rglob("*.py") if ".venv" not in p.parts)
    assert len(modules) > 200  # the walk sees the code
    leaks = [leak for path in modules for leak in family_references(path, packages)]
    assert leaks == []


def test_a_planted_family_import_is_caught_in_every_form(tmp_path: Path) -> None:
    planted = tmp_path / "planted.py"
    planted.write_text(
        "from typing import TYPE_CHECKING\n"
        "import manigraph_blocks\n"
        "if TYPE_CHECKING:\n"
        "    from manigraph_dishwasher.sim.model import DishwasherLayout\n"
        "def later():\n"
        "    import manigraph_blocks.training.recipes as recipes\n"
        "    return 'manigraph_dishwasher.skills:FAMILY'\n"
        "TEXT = 'the manigraph_blocks package, in words, is not an import'\n"
    )
    found = family_references(planted, family_packages())
    assert sorted(line.split(": ", 1)[1] for line in found) == [
        "manigraph_blocks",
        "manigraph_blocks.training.recipes",
        "manigraph_dishwasher.sim.model",
        "manigraph_dishwasher.skills:FAMILY",
    ]


#: What asks which family a layout is: an isinstance on a layout, or a family's layout named.
LAYOUT_LEAK = re.compile(r"isinstance\([^)]*Layout|DishwasherLayout|\bdishwasher\b", re.IGNORECASE)


def test_no_sim_module_asks_which_family_a_layout_is() -> None:
    package = Path(manigraph_sim.__file__).parent
    leaks = []
    for path in sorted(package.rglob("*.py")):
        lines = path.read_text().splitlines()
        leaks += [f"{path.name}: {line.strip()}" for line in lines if LAYOUT_LEAK.search(line)]
    assert leaks == []


#: Files of services/, shared/ and tools/ that still name a family, and why (issue 50's
#: target allows at most two). The contract's categories list the dishwasher's dishes.
NAMES_A_FAMILY = {"shared/manigraph_shared/messages/scene.py": {"dishwasher"}}


def test_no_service_shared_or_tools_file_names_a_family_in_words() -> None:
    """Not even in a comment, a docstring, the click page's script or its HTML: a family's
    name there is knowledge of it that an import check does not see."""
    # "blocks" is the objects' everyday name (the paper's), not only the fallback family's.
    names = {entry.name for entry in family_entry_points()} - {"blocks"}
    pattern = re.compile(rf"\b({'|'.join(sorted(names))})\b", re.IGNORECASE)
    found = {}
    for root in ("services", "shared", "tools"):
        for path in sorted((REPO / root).rglob("*")):
            if path.suffix not in {".py", ".js", ".html", ".css", ".md", ".toml"}:
                continue
            named = {match.lower() for match in pattern.findall(path.read_text())}
            relative = str(path.relative_to(REPO))
            if named - NAMES_A_FAMILY.get(relative, set()):
                found[relative] = sorted(named)
    assert found == {}
    assert len(NAMES_A_FAMILY) <= 2
