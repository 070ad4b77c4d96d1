"""The dishwasher family's options: what an episode request sets for a dishwasher task."""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_shared.options import Options, option
from manigraph_sim.tasks.base import Task


@dataclass(frozen=True)
class DishwasherOptions(Options):
    """From the request's ``objects`` and its option ``preference``; the task checks them
    (``TaskError`` naming the field)."""

    objects: int | None = option(None, help="dishes, half plates, half bowls (unset: 10)")
    preference: str | None = option(
        None, help="how to load: top-bottom or left-right (unset: top-bottom)"
    )


#: A task of the dishwasher family: its parameters are :class:`DishwasherOptions`.
DishwasherTask = Task[DishwasherOptions]
