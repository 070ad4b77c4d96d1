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

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any, Protocol, TypeVar

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Scene
from manigraph_shared.registry import import_target

__all__ = [
    "GROUP",
    "FamilyPart",
    "SceneFamily",
    "check_one_fallback",
    "family_entry_points",
    "family_of_scene",
    "family_parts",
    "register_parts",
]

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


def register_parts(service: str, part_type: type, register: Callable[[Any], Any]) -> None:
    """Register, with ``register``, the ``service`` part of every installed family package, by
    family name: each must be a ``part_type`` (an instance, or for a class registry a subclass)
    named after its family, else a ``ConfigError`` naming the family."""
    for part in family_parts(service):
        family = import_target(part.target)
        is_part = isinstance(family, part_type) or (
            isinstance(family, type) and issubclass(family, part_type)
        )
        if not is_part or getattr(family, "name", None) != part.family:
            raise ConfigError(
                f"family.{part.family}", f"{part.target} is not its {part_type.__name__}"
            )
        register(family)


class SceneFamily(Protocol):
    """What the planner's and the skills' registries ask of a family to place a scene."""

    @property
    def name(self) -> str: ...
    @property
    def fallback(self) -> bool: ...
    @property
    def matches(self) -> Callable[[Scene], bool]: ...


F = TypeVar("F", bound=SceneFamily)


def check_one_fallback(family: SceneFamily, registered: Iterable[SceneFamily]) -> None:
    """Refuse a second fallback family: which family a scene falls back to must not depend on
    the order families come in."""
    if family.fallback:
        taken = [known.name for known in registered if known.fallback]
        if taken:
            raise ConfigError("family", f"'{family.name}': '{taken[0]}' is the fallback already")


def family_of_scene(families: Iterable[F], scene: Scene) -> F:
    """The family ``scene`` belongs to: the first that matches it, else the fallback."""
    fallback = None
    for family in families:
        if family.fallback:
            fallback = family
        elif family.matches(scene):
            return family
    if fallback is None:
        raise ConfigError("family", "no family takes this scene and none is the fallback")
    return fallback
