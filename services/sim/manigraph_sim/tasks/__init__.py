"""Registered tasks: seeded initial layouts, goals and a success check."""

from manigraph_sim.tasks import stack  # noqa: F401  (registers its tasks)
from manigraph_sim.tasks.base import TASKS, Layout, Task, get_task, register_task

__all__ = ["TASKS", "Layout", "Task", "get_task", "register_task"]
