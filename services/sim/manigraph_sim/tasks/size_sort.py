"""Size sorting: small blocks into one bin, large blocks into the other.

The toy third task (issue 31): everything it brings to the sim is this module and the one
import in ``tasks/__init__.py`` that registers it. The rule needs no new world rule and no new
message field: a goal is where a block's *centre* should be, and a block resting on a bin's
floor has its centre at half its height, so a small bin's goals (centres 1.5 cm up) can only
be filled by a small block and a large bin's (3.5 cm up) only by a large one. A block of the
other size put there rests 2 cm off its goal's centre, beyond the geometric world's 1 cm
goal tolerance, and leaves the goal empty. The planner reads the same rule off node heights
(``z``), which its GNN already sees (docs/tasks/size-sort.md).
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import Task, register_task, sample_sites
from manigraph_sim.world_model import Body, Container, Goal, Layout

#: Side of a small and of a large block, metres. Their centres on a floor are 2 cm apart in
#: height: more than the geometric world's goal tolerance (1 cm), so neither fills the
#: other's goal. (6 cm, 1.5 cm apart, was sorted less often by the trained GNN:
#: docs/tasks/size-sort.md.)
SMALL = 0.03
LARGE = 0.07
#: Spacing of a bin's 2 x 2 goal grid, by block side: 1.5 cm of air between neighbours.
PITCH = {SMALL: 0.045, LARGE: 0.085}
#: A bin's inner side, by block side: the grid plus 1.25 cm of margin to each wall.
BIN_INNER = {SMALL: 0.10, LARGE: 0.18}
BIN_WALL = 0.01
BIN_HEIGHT = 0.04
#: Blocks per bin: its 2 x 2 grid.
BIN_CAPACITY = 4
#: Where bins stand (x, y), metres, and how far apart their centres are at least.
BIN_AREA = ((0.52, 0.64), (-0.28, 0.28))
BIN_DISTANCE = 0.24
#: Where loose blocks start: spots of a 2 x 8 grid in the near part of the workspace, 10 cm
#: apart (more than a large block's side even after jitter), clear of every bin.
SPOT_X = (0.27, 0.37)
SPOT_Y = tuple(-0.35 + 0.10 * j for j in range(8))
SPOT_JITTER = 0.01


def bin_goals(prefix: str, site: np.ndarray, side: float, count: int) -> list[Goal]:
    """``count`` goals on the floor of the bin at ``site``, for blocks of ``side``."""
    pitch = PITCH[side]
    cells = [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)][:count]
    return [
        Goal(
            f"{prefix}_{i}",
            "block",
            np.array([site[0] + i_x * pitch, site[1] + i_y * pitch, side / 2]),
        )
        for i, (i_x, i_y) in enumerate(cells)
    ]


def sorting_bin(name: str, site: np.ndarray, side: float) -> Container:
    return Container(name, site.copy(), np.full(2, BIN_INNER[side]), BIN_WALL, BIN_HEIGHT)


@register_task("size-sort")
class SizeSortTask(Task):
    """Sort blocks by size into two bins.

    **Task Description**: K cubes lie loose on the table, some small (3 cm), the rest large
    (7 cm). Put every small block into the small bin and every large block into the large
    bin (each bin has one goal per block of its size on its floor).

    **Randomizations**: how many blocks are small (uniformly 1..K-1, at most 4 of each size),
    which ids they get (shuffled), where each block lies (K of 16 spots 10 cm apart in the near
    part of the workspace, each jittered by up to 1 cm in x and y), and where the two bins
    stand (24 cm apart, in the far part of the workspace, either bin on either side).

    **Success Conditions**: every bin goal holds a block; a goal is only filled by a block
    of its bin's size (its centre height), so every block is in the bin of its size. The
    geometric world only: the physics world's goal tolerance (2 cm) would let a large block
    fill a small goal.
    """

    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError("stacks: size-sort has no stacks; leave stacks at 1")
        if not 2 <= self.params.blocks <= 2 * BIN_CAPACITY:
            raise TaskError(f"blocks: must be in 2..{2 * BIN_CAPACITY} (two bins of 2 x 2)")

    def layout(self, rng: np.random.Generator) -> Layout:
        k = self.params.blocks
        small = int(rng.integers(max(1, k - BIN_CAPACITY), min(k - 1, BIN_CAPACITY) + 1))
        sides = [SMALL] * small + [LARGE] * (k - small)
        order = rng.permutation(k)
        grid = [np.array([x, y]) for x in SPOT_X for y in SPOT_Y]
        chosen = rng.choice(len(grid), size=k, replace=False)
        spots = [grid[int(c)] + rng.uniform(-SPOT_JITTER, SPOT_JITTER, size=2) for c in chosen]
        bodies = [
            Body(
                f"block_{int(order[i])}",
                "block",
                np.full(3, side),
                np.array([spot[0], spot[1], side / 2]),
            )
            for i, (side, spot) in enumerate(zip(sides, spots, strict=True))
        ]
        bodies.sort(key=lambda body: body.id)
        small_site, large_site = sample_sites(rng, 2, BIN_DISTANCE, area=BIN_AREA)
        goals = bin_goals("small_goal", small_site, SMALL, small)
        goals += bin_goals("large_goal", large_site, LARGE, k - small)
        bins = [
            sorting_bin("small_bin", small_site, SMALL),
            sorting_bin("large_bin", large_site, LARGE),
        ]
        return Layout(bodies, goals, bins)
