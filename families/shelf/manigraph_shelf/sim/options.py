"""The shelf family's options: what an episode request sets for a shelf task."""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_shared.options import Options, option
from manigraph_sim.tasks.base import Task


@dataclass(frozen=True)
class ShelfOptions(Options):
    """From the request's ``objects``; the task checks it (``TaskError`` naming it)."""

    objects: int | None = option(None, help="blocks and slots, even, 2..18 (unset: 4)")


#: A task of the shelf family: its parameters are :class:`ShelfOptions`.
ShelfTask = Task[ShelfOptions]
