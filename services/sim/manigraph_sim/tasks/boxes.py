"""Box packing, unpacking and rearrangement: boxes with covers that must be lifted off."""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import TaskError
from manigraph_sim.geometric.world import Body, Container, Goal
from manigraph_sim.tasks.base import (
    BLOCK_SIZE,
    Layout,
    Task,
    register_task,
    sample_sites,
    stack_bodies,
    stack_goals,
)

BOX_INNER = 0.14  # room for a 3 x 3 grid of blocks
BOX_WALL = 0.01
BOX_HEIGHT = 0.06
COVER_SIZE = np.array([BOX_INNER + 2 * BOX_WALL, BOX_INNER + 2 * BOX_WALL, 0.01])
GRID_PITCH = 0.045
MAX_BLOCKS = 9
#: Sites (boxes, stacks, cover storage) keep this far apart so nothing overlaps.
SITE_DISTANCE = 0.2


def box_at(name: str, site: np.ndarray) -> Container:
    return Container(name, site.copy(), np.full(2, BOX_INNER), BOX_WALL, BOX_HEIGHT)


def lid_height() -> float:
    return BOX_HEIGHT + COVER_SIZE[2] / 2


def cover_on(name: str, site: np.ndarray) -> Body:
    return Body(name, "cover", COVER_SIZE.copy(), np.array([site[0], site[1], lid_height()]))


def lid_goal(name: str, site: np.ndarray) -> Goal:
    return Goal(name, "cover", np.array([site[0], site[1], lid_height()]))


def storage_goal(name: str, site: np.ndarray) -> Goal:
    return Goal(name, "cover", np.array([site[0], site[1], COVER_SIZE[2] / 2]))


def grid(site: np.ndarray, count: int) -> list[np.ndarray]:
    """``count`` block centres inside a box, row by row on its floor."""
    cells = [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)]
    cells.sort(key=lambda c: (abs(c[0]) + abs(c[1]), c))  # centre first, then around it
    return [
        np.array([site[0] + i * GRID_PITCH, site[1] + j * GRID_PITCH, BLOCK_SIZE / 2])
        for i, j in cells[:count]
    ]


class BoxTask(Task):
    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError(f"stacks: {self.name} has one stack of blocks")
        if not 1 <= self.params.blocks <= MAX_BLOCKS:
            raise TaskError(f"blocks: must be in 1..{MAX_BLOCKS} (one box layer)")

    def max_steps(self, goals: int) -> int:
        return 2 * goals + 6


@register_task("box-pack")
class BoxPackTask(BoxTask):
    """Box packing (a training task).

    **Task Description**: K blocks stand in a stack beside a closed box; take the cover off
    (onto its storage place on the table), put every block into the box, close the box.

    **Randomizations**: the box, stack and storage sites.

    **Success Conditions**: every block goal in the box holds a block and the cover is back on
    the box; the storage place may be empty.
    """

    def layout(self, rng: np.random.Generator) -> Layout:
        box_site, stack_site, store_site = sample_sites(rng, 3, SITE_DISTANCE)
        k = self.params.blocks
        goals = [Goal(f"goal_{i}", "block", centre) for i, centre in enumerate(grid(box_site, k))]
        goals += [lid_goal("lid_goal_0", box_site), storage_goal("storage_0", store_site)]
        bodies = [*stack_bodies("block", stack_site, k), cover_on("cover_0", box_site)]
        return Layout(bodies, goals, [box_at("box_0", box_site)], {"storage_0"})


@register_task("box-unpack")
class BoxUnpackTask(BoxTask):
    """Box unpacking (a training task).

    **Task Description**: K blocks lie in a closed box; take the cover off, stack the blocks
    on the goal stack on the table, close the box.

    **Randomizations**: the box, goal stack and storage sites.

    **Success Conditions**: every goal of the stack holds a block and the cover is back on the
    box.
    """

    def layout(self, rng: np.random.Generator) -> Layout:
        box_site, stack_site, store_site = sample_sites(rng, 3, SITE_DISTANCE)
        k = self.params.blocks
        bodies = [
            Body(f"block_{i}", "block", np.full(3, BLOCK_SIZE), c)
            for i, c in enumerate(grid(box_site, k))
        ]
        bodies.append(cover_on("cover_0", box_site))
        goals = stack_goals("goal", stack_site, k)
        goals += [lid_goal("lid_goal_0", box_site), storage_goal("storage_0", store_site)]
        return Layout(bodies, goals, [box_at("box_0", box_site)], {"storage_0"})


@register_task("box-rearrangement")
class BoxRearrangementTask(BoxTask):
    """Box rearrangement (a test task: partial observability).

    **Task Description**: two closed boxes, one holding K blocks; open both (covers onto
    storage places on the table), move every block into the other box, close both boxes.
    What is inside a closed box is not observed until the box is opened: blocks and their goals
    appear as nodes once their box has been open (and stay known after it is closed again).

    **Randomizations**: the two box sites and the two storage sites.

    **Success Conditions**: every block goal in the empty box holds a block and both covers
    are back on their boxes.
    """

    def layout(self, rng: np.random.Generator) -> Layout:
        full_site, empty_site, store_a, store_b = sample_sites(rng, 4, SITE_DISTANCE)
        k = self.params.blocks
        bodies = [
            Body(f"block_{i}", "block", np.full(3, BLOCK_SIZE), c)
            for i, c in enumerate(grid(full_site, k))
        ]
        bodies += [cover_on("cover_0", full_site), cover_on("cover_1", empty_site)]
        goals = [Goal(f"goal_{i}", "block", c) for i, c in enumerate(grid(empty_site, k))]
        goals += [
            lid_goal("lid_goal_0", full_site),
            lid_goal("lid_goal_1", empty_site),
            storage_goal("storage_0", store_a),
            storage_goal("storage_1", store_b),
        ]
        return Layout(
            bodies,
            goals,
            [box_at("box_0", full_site), box_at("box_1", empty_site)],
            {"storage_0", "storage_1"},
            partially_observable=True,
        )
