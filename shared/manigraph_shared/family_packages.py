"""The installed task-family packages (``families/<name>/`` in the repository, docs/families.md).

A family package declares itself with one entry point in the ``manigraph.families`` group,
named after the family, whose target is a dict: for each service the family extends, the
``"module:attribute"`` of its part there::

    [project.entry-points."manigraph.families"]
    blocks = "manigraph_blocks:PARTS"

    PARTS = {"sim": "manigraph_blocks.sim.family:BlocksFamily", ...}

Each service's family registry (``manigraph_sim.family``, ``manigraph_planner.family``,
``manigraph_skills.family``) reads its parts from :func:`family_parts` when it is first read,
and registers them; nothing else imports a family package. The order is the families'
names, whatever order the entry points come in.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points

from manigraph_shared.errors import ConfigError

__all__ = ["GROUP", "FamilyPart", "family_entry_points", "family_parts"]

#: The entry-point group a family package declares itself in.
GROUP = "manigraph.families"


@dataclass(frozen=True)
class FamilyPart:
    """One family's part for one service: ``target`` is its ``"module:attribute"``."""

    family: str
    target: str


def family_entry_points() -> list[EntryPoint]:
    """The installed families' entry points, by family name (``ConfigError`` for a name
    declared twice)."""
    found = sorted(entry_points(group=GROUP), key=lambda entry: entry.name)
    names = [entry.name for entry in found]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ConfigError("family", f"declared by two packages: {', '.join(twice)}")
    return found


def family_parts(service: str) -> list[FamilyPart]:
    """The part of each installed family that extends ``service`` (``sim``, ``planner``,
    ``skills``), by family name; a family without a part there is left out. A declaration that
    is not a dict of ``"module:attribute"`` strings is a ``ConfigError`` naming the family."""
    parts = []
    for entry in family_entry_points():
        declared = entry.load()
        if not isinstance(declared, dict) or not all(
            isinstance(key, str) and isinstance(value, str) and ":" in value
            for key, value in declared.items()
        ):
            raise ConfigError(
                f"family.{entry.name}", f"{entry.value} is not a dict of 'module:attribute'"
            )
        if service in declared:
            parts.append(FamilyPart(entry.name, declared[service]))
    return parts
