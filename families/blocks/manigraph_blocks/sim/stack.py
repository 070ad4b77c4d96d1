"""K-block stacking and its multi-stack variant."""

from __future__ import annotations

import numpy as np

from manigraph_blocks.sim.options import BlockTask
from manigraph_blocks.sim.placement import sample_sites, stack_bodies, stack_goals
from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import register_task
from manigraph_sim.world_model import BLOCK_SIZE, Layout


@register_task("stack")
class StackTask(BlockTask):
    """K-block stacking.

    **Task Description**: K blocks stand in one stack; build the inverted stack at another
    place (the top block goes to the bottom goal).

    **Randomizations**: the stack's and the goal stack's table positions, uniformly in the
    workspace, at least three block widths apart.

    **Success Conditions**: every goal holds a block (centre within the goal tolerance).
    """

    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError("stacks: stack has exactly one stack; use multistack for more")
        if not 1 <= self.params.blocks <= 64:
            raise TaskError("blocks: must be in 1..64")

    def layout(self, rng: np.random.Generator) -> Layout:
        start, goal = sample_sites(rng, 2, min_distance=3 * BLOCK_SIZE)
        k = self.params.blocks
        return Layout(stack_bodies("block", start, k), stack_goals("goal", goal, k))


@register_task("multistack")
class MultiStackTask(BlockTask):
    """K-block s-stack.

    **Task Description**: s stacks of K blocks each; build s inverted goal stacks elsewhere.

    **Randomizations**: the 2s stack sites, uniformly in the workspace, three block widths apart.

    **Success Conditions**: every goal holds a block.
    """

    def validate(self) -> None:
        if not 1 <= self.params.stacks <= 6:
            raise TaskError("stacks: must be in 1..6")
        if not 1 <= self.params.blocks <= 16:
            raise TaskError("blocks: must be in 1..16 per stack")

    def layout(self, rng: np.random.Generator) -> Layout:
        k, s = self.params.blocks, self.params.stacks
        sites = sample_sites(rng, 2 * s, min_distance=3 * BLOCK_SIZE)
        bodies, goals = [], []
        for i in range(s):
            bodies += stack_bodies("block", sites[i], k, first=i * k)
            goals += stack_goals("goal", sites[s + i], k, first=i * k)
        return Layout(bodies, goals)
