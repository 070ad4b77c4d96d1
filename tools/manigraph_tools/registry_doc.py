"""The registry table of docs/architecture.md, generated from the registries themselves.

Each swappable part is an entry of one :class:`~manigraph_shared.registry.Registry`; this
module imports the packages that fill each registry (a registry fills as its package's modules
register their entries, or the installed task families' when it is first read) and lists what
is there, so the page cannot drift from the code (``tests/test_readme.py`` checks every
generated block). A family's own registries (the generic trainer's recipes) are found through
the planner's family registry, never by the family's name.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from manigraph_shared.registry import Registry

#: (registry, the module that declares it, the package whose import fills it), in the order
#: an episode meets them.
REGISTRIES: tuple[tuple[str, str, str], ...] = (
    ("BACKENDS", "manigraph_sim.backends", "manigraph_sim.backends"),
    ("TASKS", "manigraph_sim.tasks.base", "manigraph_sim.tasks"),
    ("FAMILIES", "manigraph_sim.family", "manigraph_sim.family"),
    ("DRIVERS", "manigraph_skills.drivers.registry", "manigraph_skills.drivers"),
    ("FAMILIES", "manigraph_skills.family", "manigraph_skills.family"),
    ("PIPELINES", "manigraph_perception.registry", "manigraph_perception.registry"),
    ("POLICIES", "manigraph_planner.policies.base", "manigraph_planner.policies"),
    ("POLICY_FILE_LOADERS", "manigraph_planner.policies.base", "manigraph_planner.policies"),
    ("HEADS", "manigraph_planner.gnn.models.config", "manigraph_planner.gnn.models"),
    ("ARCHITECTURES", "manigraph_planner.gnn.models.backbone", "manigraph_planner.gnn.models"),
    ("SOURCES", "manigraph_training.sources", "manigraph_training.sources"),
    ("BATCH_LAYOUTS", "manigraph_training.batch_layouts", "manigraph_training"),
    ("FAMILIES", "manigraph_planner.family", "manigraph_planner.family"),
    ("FAMILIES", "manigraph_tools.family", "manigraph_tools.family"),
    ("FORMATS", "manigraph_tools.interop.formats", "manigraph_tools.interop.formats"),
    ("BASELINES", "manigraph_lab.rl.baselines", "manigraph_lab.rl.baselines"),
)


def _where(module_name: str) -> str:
    """The module's file, from the repository root (``services/sim/...``)."""
    path = Path(importlib.import_module(module_name).__file__ or module_name)
    parts = path.parts
    for root in ("services", "shared", "tools", "lab", "families", "training"):
        if root in parts:
            index = len(parts) - 1 - parts[::-1].index(root)
            return "/".join(parts[index:])
    return path.name


def _options(registry: Registry[object]) -> str:
    names = []
    for name in sorted(registry):
        options = registry.entry(name).options
        label = options.__name__ if options is not None else "none"
        if label not in names:
            names.append(label)
    return ", ".join(f"`{n}`" if n != "none" else n for n in names) or "none"


def registry_table() -> str:
    """One row per registry: where it is declared, its entries and their options classes."""
    rows = ["| registry | where | entries | options |", "|---|---|---|---|"]
    for attribute, module_name, filler in _rows():
        importlib.import_module(filler)
        registry: Registry[object] = getattr(importlib.import_module(module_name), attribute)
        # by name: the order entries register in depends on what a process imported first
        entries = ", ".join(sorted(registry.names())) or "(none)"
        rows.append(
            f"| `{attribute}` | `{_where(module_name)}` | {entries} | {_options(registry)} |"
        )
    return "\n".join(rows)


def _rows() -> list[tuple[str, str, str]]:
    """:data:`REGISTRIES`, with the registries the planner's families name as their recipes
    after the planner's family registry."""
    from manigraph_planner.family import FAMILIES

    rows = []
    for row in REGISTRIES:
        rows.append(row)
        if row[1] == "manigraph_planner.family":
            for _, family in FAMILIES.items():
                if family.recipe is not None:
                    module_name, _, attribute = family.recipe.partition(":")
                    rows.append((attribute, module_name, module_name))
    return rows
