"""A task = a registered class that lays out a seeded episode and says when it succeeded."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, Generic, TypeVar

import numpy as np

from manigraph_shared.registry import Registry
from manigraph_sim.world_model import Layout

#: A task's parameters: its family's options (``manigraph_sim.family``).
P = TypeVar("P")


class Task(ABC, Generic[P]):
    """Subclasses document Task Description / Randomizations / Success Conditions. A task
    belongs to a family (``manigraph_sim.family``), whose options are its ``params``."""

    name: str

    def __init__(self, params: P) -> None:
        self.params = params
        self.validate()

    def validate(self) -> None:
        """Raise ``TaskError`` naming the parameter that does not fit this task."""

    @abstractmethod
    def layout(self, rng: np.random.Generator) -> Layout: ...

    def max_steps(self, goals: int) -> int:
        return 2 * goals + 4


#: Tasks by name. A task takes no options of its own: its parameters are its family's options
#: (``FAMILIES``), built from each episode request, and :meth:`Task.validate` checks them.
#: Each installed family registers its tasks when this is first read (``manigraph_sim.family``
#: says so where it is imported; ``manigraph_sim.tasks`` imports it).
TASKS: Registry[type[Task[Any]]] = Registry("task")
register_task = TASKS.register


def get_task(name: str, params: Any) -> Task[Any]:
    """Task ``name`` with ``params`` (its family's options); ``ConfigError`` naming the known
    tasks if unknown."""
    return TASKS[name](params)
