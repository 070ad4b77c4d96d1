"""What every sim backend does first on a reset: the request's task, laid out with its seed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.dishwasher.model import DishwasherLayout
from manigraph_sim.tasks.base import Task, TaskParams, get_task
from manigraph_sim.tasks.box_geometry import BoxGeometry
from manigraph_sim.tasks.task_file import FileTask, parse_task_file
from manigraph_sim.world_model import Layout


@dataclass(frozen=True)
class EpisodeLayout:
    """A validated, seeded layout and the episode's step budget."""

    layout: Layout
    max_steps: int


def episode_layout(request: EpisodeRequest, boxes: BoxGeometry | None = None) -> EpisodeLayout:
    """The layout of ``request``: a registered task, or the user's task file (its text travels
    in the request); box tasks with ``boxes`` (default: the geometric world's geometry).
    Raises ``TaskError`` naming the field for a bad task or file."""
    if request.task == "file" or request.task_file is not None:
        if request.task_file is None:
            raise TaskError("task_file: task 'file' needs the task file's text")
        task: Task = FileTask(parse_task_file(request.task_file))
    else:
        params = TaskParams(
            blocks=request.blocks,
            stacks=request.stacks,
            boxes=boxes,
            objects=request.objects,
            preference=request.preference,
        )
        task = get_task(request.task, params)
    layout = task.layout(np.random.default_rng(request.seed))
    layout.validate()
    size = len(layout.dishes) if isinstance(layout, DishwasherLayout) else len(layout.goals)
    return EpisodeLayout(layout, request.max_steps or task.max_steps(size))
