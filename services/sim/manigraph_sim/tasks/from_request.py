"""What every sim backend does first on a reset: the request's task, laid out with its seed
by the task's family."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.family import SimFamily, family_of
from manigraph_sim.world_model import Layout


@dataclass(frozen=True)
class EpisodeLayout:
    """A validated, seeded layout, the episode's step budget, and the family that owns it
    (its world adapters and success check)."""

    layout: Layout
    max_steps: int
    family: SimFamily


def episode_layout(request: EpisodeRequest, geometry: str = "geometric") -> EpisodeLayout:
    """The layout of ``request``: a registered task, or the user's task file (its text travels
    in the request), laid out in ``geometry``'s world (``geometric`` or ``physics``: the box
    tasks' geometry). Raises ``TaskError`` or ``ConfigError`` naming the field for a bad task,
    file or a field of another family."""
    family = family_of(request)
    task = family.task(request, geometry)
    layout = task.layout(np.random.default_rng(request.seed))
    layout.validate()
    return EpisodeLayout(layout, request.max_steps or family.max_steps(task, layout), family)


def check_request(request: EpisodeRequest) -> None:
    """Refuse ``request``'s task file where the query arrives, before the sim's thread sees
    it: read and checked (the goal matching included) on the thread that got the query, so a
    hostile file never holds the thread that moves the robot. A file's outcome is kept
    (``parse_task_file``): the reset lays a checked file out without checking it again.
    Raises ``TaskError`` or ``ConfigError``; a request without a file is the reset's to check."""
    if request.task_file is not None:
        family_of(request).task(request)
