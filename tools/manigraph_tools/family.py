"""A task family's part of the episode commands, as one registered unit (docs/families.md).

``manigraph run``, ``up`` and ``eval`` name their episodes after the task and K, describe
them by K in progress lines and size them by blocks and stacks in the summary
(:mod:`manigraph_tools.episode_plan`). A family whose episodes are sized otherwise (by a
count of objects and options of its own) says so here, in the ``tools`` part of its package
(``families/<name>/``), which names its :class:`ToolsFamily` in the package's
``manigraph.families`` entry point (:mod:`manigraph_shared.family_packages`); :data:`FAMILIES`
registers every installed one, by name, when it is first read. The episode commands ask the
registry (:func:`family_of_task`), never which family a task is.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from manigraph_shared.errors import ConfigError
from manigraph_shared.family_packages import register_parts
from manigraph_shared.registry import Registry

__all__ = ["FAMILIES", "ToolsFamily", "family_of_task", "register_family"]


@dataclass(frozen=True)
class ToolsFamily:
    """One task family's episode sizing.

    Args:
        name: the family (its entry point's name), as in the services' registries.
        tasks: its task names (``--task``).
        sized_by: the ``EpisodeOptions`` fields its episodes are sized by, in the summary
            instead of blocks and stacks; the first is the count that names and describes
            them (``<task>-<count>``, ``<task> <count> <counted> <the others>``).
        counted: what the count counts, in progress lines (``dishes``).
        expert_of: the registered name of the expert that plays its episodes in ``manigraph
            up`` when no policy is named, from the run's episode options (``preference``,
            ``objects``, ...); None: the ``expert`` policy. A rule the planner part reads too
            (which expert demonstrates a request) goes in a common module of the package.
        fixture_actions: the family action each kind of its fixtures takes on the
            demonstration page (a fixture's button sends it; ``Action.family_action``).
    """

    name: str
    tasks: tuple[str, ...]
    sized_by: tuple[str, ...]
    counted: str
    expert_of: Callable[[Mapping[str, Any]], str] | None = None
    help: str = ""
    fixture_actions: Mapping[str, str] = field(default_factory=dict)


def _register_installed() -> None:
    """Register the ``tools`` part of every installed family package, by family name."""
    register_parts("tools", ToolsFamily, register_family)


#: Every task family whose episodes the episode commands size its own way, by name: the
#: installed family packages' are registered when it is first read.
FAMILIES: Registry[ToolsFamily] = Registry("family", fill=_register_installed)


def register_family(family: ToolsFamily) -> ToolsFamily:
    """Add ``family`` to :data:`FAMILIES` (``ConfigError`` for a family without sizes)."""
    if not family.sized_by:
        raise ConfigError(f"family.{family.name}", "sized_by: name at least its count")
    FAMILIES.add(family.name, family, help=family.help)
    return family


def family_of_task(task: str) -> ToolsFamily | None:
    """The family whose task ``task`` is, or None: its episodes are sized by blocks and
    stacks (every task no family here claims, and a task file)."""
    return next((family for _, family in FAMILIES.items() if task in family.tasks), None)
