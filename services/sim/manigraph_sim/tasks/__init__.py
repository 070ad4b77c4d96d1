"""Registered tasks: seeded initial layouts, goals and a success check.

Each task belongs to a task family (``manigraph_sim.family``), which registers it; the
installed families' tasks are registered when ``TASKS`` is first read."""

from manigraph_sim import family as _family  # noqa: F401  (fills TASKS with the families')
from manigraph_sim.tasks.base import TASKS, Task, get_task, register_task
from manigraph_sim.world_model import Layout

__all__ = ["TASKS", "Layout", "Task", "get_task", "register_task"]
