"""Registered tasks: seeded initial layouts, goals and a success check."""

from manigraph_sim.dishwasher import task as _dishwasher  # noqa: F401  (registers its task)
from manigraph_sim.tasks import boxes, pyramid, size_sort, stack  # noqa: F401  (register their tasks)
from manigraph_sim.tasks.base import TASKS, Task, get_task, register_task
from manigraph_sim.world_model import Layout

__all__ = ["TASKS", "Layout", "Task", "get_task", "register_task"]
