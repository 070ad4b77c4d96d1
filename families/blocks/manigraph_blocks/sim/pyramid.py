"""K-pyramid: the stacking task with pyramid-shaped goals."""

from __future__ import annotations

import numpy as np

from manigraph_blocks.sim.options import BlockTask
from manigraph_blocks.sim.placement import sample_sites, stack_bodies
from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import register_task
from manigraph_sim.world_model import BLOCK_SIZE, Goal, Layout

#: Gap between neighbouring blocks of a pyramid row, metres.
ROW_GAP = 0.004


def pyramid_goals(base: np.ndarray, count: int) -> list[Goal]:
    """``count`` goals filling a pyramid bottom row first; each upper goal sits on two below."""
    width = 1
    while width * (width + 1) // 2 < count:
        width += 1
    pitch = BLOCK_SIZE + ROW_GAP
    goals: list[Goal] = []
    for level in range(width):
        row = width - level
        for i in range(row):
            if len(goals) == count:
                return goals
            y = base[1] + (i - (row - 1) / 2) * pitch
            z = (level + 0.5) * BLOCK_SIZE
            goals.append(Goal(f"goal_{len(goals)}", "block", np.array([base[0], y, z])))
    return goals


@register_task("pyramid")
class PyramidTask(BlockTask):
    """K-pyramid.

    **Task Description**: K blocks stand in one stack; build a pyramid with them (rows of
    width w, w-1, ... 1, filled bottom row first, a partial top row for non-triangular K).

    **Randomizations**: the stack's and the pyramid's table positions.

    **Success Conditions**: every goal holds a block.
    """

    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError("stacks: pyramid has exactly one stack")
        if not 1 <= self.params.blocks <= 36:
            raise TaskError("blocks: must be in 1..36")

    def layout(self, rng: np.random.Generator) -> Layout:
        k = self.params.blocks
        width = int(np.ceil((np.sqrt(8 * k + 1) - 1) / 2))
        spacing = (width + 3) * BLOCK_SIZE
        start, base = sample_sites(rng, 2, min_distance=spacing)
        return Layout(stack_bodies("block", start, k), pyramid_goals(base, k))
