"""A task = a registered class that lays out a seeded episode and says when it succeeded."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manigraph_shared.errors import TaskError
from manigraph_sim.geometric.world import Body, Container, Goal

BLOCK_SIZE = 0.04
#: Where stacks and boxes may be placed, robot frame, metres: in front of a Panda.
WORKSPACE_X = (0.30, 0.70)
WORKSPACE_Y = (-0.35, 0.35)


@dataclass
class Layout:
    bodies: list[Body]
    goals: list[Goal]
    containers: list[Container] = field(default_factory=list)
    #: Goals that may stay empty at the end (storage places for covers).
    optional_goals: set[str] = field(default_factory=set)
    partially_observable: bool = False

    def required_goals(self) -> set[str]:
        return {goal.id for goal in self.goals} - self.optional_goals

    def validate(self) -> None:
        names = [b.id for b in self.bodies] + [g.id for g in self.goals]
        if len(names) != len(set(names)):
            raise TaskError("layout: object and goal ids must be unique")
        if not self.required_goals():
            raise TaskError("layout: at least one goal must be required")


@dataclass(frozen=True)
class TaskParams:
    blocks: int = 4
    stacks: int = 1


class Task(ABC):
    """Subclasses document Task Description / Randomizations / Success Conditions."""

    name: str

    def __init__(self, params: TaskParams) -> None:
        self.params = params
        self.validate()

    def validate(self) -> None:
        """Raise ``TaskError`` naming the parameter that does not fit this task."""

    @abstractmethod
    def layout(self, rng: np.random.Generator) -> Layout: ...

    def max_steps(self, goals: int) -> int:
        return 2 * goals + 4


TASKS: dict[str, type[Task]] = {}


def register_task(name: str) -> Callable[[type[Task]], type[Task]]:
    def register(cls: type[Task]) -> type[Task]:
        cls.name = name
        TASKS[name] = cls
        return cls

    return register


def get_task(name: str, params: TaskParams) -> Task:
    cls = TASKS.get(name)
    if cls is None:
        raise TaskError(f"task: unknown task '{name}' (known: {', '.join(sorted(TASKS))})")
    return cls(params)


def stack_bodies(prefix: str, base: np.ndarray, count: int, first: int = 0) -> list[Body]:
    size = np.full(3, BLOCK_SIZE)
    return [
        Body(
            id=f"{prefix}_{first + i}",
            category="block",
            size=size.copy(),
            position=np.array([base[0], base[1], (i + 0.5) * BLOCK_SIZE]),
        )
        for i in range(count)
    ]


def stack_goals(prefix: str, base: np.ndarray, count: int, first: int = 0) -> list[Goal]:
    return [
        Goal(
            id=f"{prefix}_{first + i}",
            category="block",
            position=np.array([base[0], base[1], (i + 0.5) * BLOCK_SIZE]),
        )
        for i in range(count)
    ]


def sample_sites(rng: np.random.Generator, count: int, min_distance: float) -> list[np.ndarray]:
    """``count`` table positions at least ``min_distance`` apart, inside the workspace."""
    for _ in range(1000):
        sites = [
            np.array([rng.uniform(*WORKSPACE_X), rng.uniform(*WORKSPACE_Y)]) for _ in range(count)
        ]
        if all(
            np.linalg.norm(a - b) >= min_distance
            for i, a in enumerate(sites)
            for b in sites[i + 1 :]
        ):
            return sites
    raise TaskError(f"cannot fit {count} sites {min_distance} m apart in the workspace")
