"""Registered tasks: seeded initial layouts, goals and a success check.

Each task belongs to a task family (``manigraph_sim.families``), which registers it; importing
this package registers every family's tasks."""

from manigraph_sim import families as _families  # noqa: F401  (registers every family's tasks)
from manigraph_sim.tasks.base import TASKS, Task, get_task, register_task
from manigraph_sim.world_model import Layout

__all__ = ["TASKS", "Layout", "Task", "get_task", "register_task"]
