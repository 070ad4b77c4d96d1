"""The sim's ground floor: the world model every backend and task shares.

What lies on the table (:class:`Body`: blocks and covers), where it should go (:class:`Goal`),
the static open-top boxes (:class:`Container`), a task's seeded :class:`Layout` of them, and
the sizes and workspace they are laid out in. The geometric world, the physics world, the
tasks and the task files all build on these records; this module imports nothing else from
``manigraph_sim`` (a test checks), so nothing here can be part of an import cycle.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Final

import numpy as np

from manigraph_shared.acceptance import admits
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import Vector3

#: The object and goal categories: a block fills a block goal, a cover a cover goal.
BLOCK: Final = "block"
COVER: Final = "cover"
CATEGORIES: Final = (BLOCK, COVER)

#: A block's side, metres.
BLOCK_SIZE = 0.04
#: Where stacks and boxes may be placed, robot frame, metres: in front of a Panda.
WORKSPACE_X = (0.30, 0.70)
WORKSPACE_Y = (-0.35, 0.35)


#: Footprints must overlap by more than this (metres) to support or cover one another.
CONTACT_MARGIN = 0.002


@dataclass
class Body:
    id: str
    category: str  # "block" | "cover"
    size: np.ndarray  # full extents (x, y, z), metres
    position: np.ndarray  # centre, metres
    #: What the task tells objects apart by (colour, label, ...): text or number.
    attributes: dict[str, str | float] = field(default_factory=dict)

    @property
    def bottom(self) -> float:
        return float(self.position[2] - self.size[2] / 2)

    @property
    def top(self) -> float:
        return float(self.position[2] + self.size[2] / 2)


@dataclass
class Goal:
    id: str
    category: str  # "block" | "cover": which objects fill it
    position: np.ndarray
    #: What an object must carry to fill it: every key must match (an attribute's value,
    #: ``id``, or ``size`` within 1 mm); empty: any object of its category.
    accepts: dict[str, str | float | list[float]] = field(default_factory=dict)
    #: What the task tells goals apart by (a bin's colour, a rack's side): text or number.
    attributes: dict[str, str | float] = field(default_factory=dict)

    def admits(self, body: Body) -> bool:
        """Whether ``body`` may fill this goal: its category, and all that ``accepts`` lists."""
        return body.category == self.category and admits(
            self.accepts, body.id, body.size.tolist(), body.attributes
        )


@dataclass
class Container:
    """A static open-top box standing on the table."""

    id: str
    centre: np.ndarray  # (x, y)
    inner: np.ndarray  # inner extents (x, y), metres
    wall: float
    height: float  # rim height above the table

    def fits_inside(self, position: np.ndarray, size: np.ndarray) -> bool:
        gap = np.abs(position[:2] - self.centre) + size[:2] / 2 - self.inner / 2
        return bool(np.all(gap <= CONTACT_MARGIN))

    def touches(self, position: np.ndarray, size: np.ndarray) -> bool:
        outer = self.inner + 2 * self.wall
        gap = np.abs(position[:2] - self.centre) - (size[:2] + outer) / 2
        return bool(np.all(gap < -CONTACT_MARGIN))

    def holds_point(self, point: np.ndarray) -> bool:
        inside = np.all(np.abs(point[:2] - self.centre) <= self.inner / 2)
        return bool(inside and point[2] < self.height)


@dataclass
class Judge:
    """Rules only the judge knows (an ``EpisodeRequest``'s ``rules``, docs/task-files.md):
    each goal as the rules see it (its ``accepts`` the file's and the rules' together), and
    the placements that broke them, counted even when later undone. Never part of a Scene."""

    goals: dict[str, Goal]
    #: Placements into a goal the rules do not accept, so far this episode.
    violations: int = 0
    _standing: set[tuple[str, str]] | None = None

    def watch(self, wrong: Mapping[str, str]) -> None:
        """Count each (goal, object) pair in ``wrong`` (goal id -> the object standing in it
        that the rules refuse) that was not there at the last look; the first look, the laid
        out scene, counts nothing (nobody placed it)."""
        now = set(wrong.items())
        if self._standing is not None:
            self.violations += len(now - self._standing)
        self._standing = now


@dataclass
class Layout:
    """A task's seeded episode: what lies where, which goals must be filled."""

    bodies: list[Body]
    goals: list[Goal]
    containers: list[Container] = field(default_factory=list)
    #: Goals that may stay empty at the end (storage places for covers).
    optional_goals: set[str] = field(default_factory=set)
    partially_observable: bool = False
    #: The judge's rules, where the request brought some: success, wrong objects and rule
    #: violations are decided by them; the Scene and TaskLayout never see them.
    judge: Judge | None = None

    def required_goals(self) -> set[str]:
        return {goal.id for goal in self.goals} - self.optional_goals

    def validate(self) -> None:
        names = [b.id for b in self.bodies] + [g.id for g in self.goals]
        if len(names) != len(set(names)):
            raise TaskError("layout: object and goal ids must be unique")
        if not self.required_goals():
            raise TaskError("layout: at least one goal must be required")


def vector(values: np.ndarray) -> Vector3:
    """A numpy 3-vector as the contract's ``Vector3`` (what every family's Scene is made of)."""
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))
