"""The block family's options: what an episode request sets for a block task."""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_blocks.sim.box_geometry import BoxGeometry
from manigraph_shared.options import Options, option
from manigraph_sim.tasks.base import Task


@dataclass(frozen=True)
class BlockOptions(Options):
    """From the request's ``blocks`` and ``stacks``; ``boxes`` from the world the backend lays
    the tasks out in (``BlocksFamily.geometry_options``). Each task checks the ranges it
    takes (:meth:`Task.validate`, a ``TaskError`` naming the field)."""

    blocks: int = option(4, help="blocks per stack (K)")
    stacks: int = option(1, help="number of stacks (s)")
    boxes: BoxGeometry | None = option(
        None, help="the box tasks' geometry (unset: the geometric world's)", flag=False
    )


#: A task of the block family: its parameters are :class:`BlockOptions`.
BlockTask = Task[BlockOptions]
