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
    sample_square_sites,
    stack_bodies,
    stack_goals,
)
from manigraph_sim.tasks.box_geometry import BoxGeometry


def box_at(name: str, site: np.ndarray, geometry: BoxGeometry) -> Container:
    inner = np.full(2, geometry.inner)
    return Container(name, site.copy(), inner, geometry.wall, geometry.height)


def cover_on(name: str, site: np.ndarray, geometry: BoxGeometry) -> Body:
    position = np.array([site[0], site[1], geometry.lid_height])
    return Body(name, "cover", geometry.cover_size, position)


def lid_goal(name: str, site: np.ndarray, geometry: BoxGeometry) -> Goal:
    return Goal(name, "cover", np.array([site[0], site[1], geometry.lid_height]))


def storage_goal(name: str, site: np.ndarray, geometry: BoxGeometry) -> Goal:
    return Goal(name, "cover", np.array([site[0], site[1], geometry.cover_thickness / 2]))


class BoxTask(Task):
    """The box tasks share a geometry (``TaskParams.boxes``) and how they place sites."""

    @property
    def geometry(self) -> BoxGeometry:
        return self.params.boxes or BoxGeometry()

    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError(f"stacks: {self.name} has one stack of blocks")
        most = self.geometry.max_blocks
        if not 1 <= self.params.blocks <= most:
            raise TaskError(f"blocks: must be in 1..{most} (one box layer)")

    def sites(self, rng: np.random.Generator, count: int) -> list[np.ndarray]:
        g = self.geometry
        area = (g.site_x, g.site_y)
        if g.square_sites:
            return sample_square_sites(rng, count, g.site_distance, area)
        return sample_sites(rng, count, g.site_distance, area)

    def grid(self, site: np.ndarray) -> list[np.ndarray]:
        return self.geometry.grid(site, self.params.blocks, BLOCK_SIZE)

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
        g = self.geometry
        box_site, stack_site, store_site = self.sites(rng, 3)
        k = self.params.blocks
        goals = [Goal(f"goal_{i}", "block", centre) for i, centre in enumerate(self.grid(box_site))]
        goals += [lid_goal("lid_goal_0", box_site, g), storage_goal("storage_0", store_site, g)]
        bodies = [*stack_bodies("block", stack_site, k), cover_on("cover_0", box_site, g)]
        return Layout(bodies, goals, [box_at("box_0", box_site, g)], {"storage_0"})


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
        g = self.geometry
        box_site, stack_site, store_site = self.sites(rng, 3)
        bodies = [
            Body(f"block_{i}", "block", np.full(3, BLOCK_SIZE), c)
            for i, c in enumerate(self.grid(box_site))
        ]
        bodies.append(cover_on("cover_0", box_site, g))
        goals = stack_goals("goal", stack_site, self.params.blocks)
        goals += [lid_goal("lid_goal_0", box_site, g), storage_goal("storage_0", store_site, g)]
        return Layout(bodies, goals, [box_at("box_0", box_site, g)], {"storage_0"})


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
        g = self.geometry
        full_site, empty_site, store_a, store_b = self.sites(rng, 4)
        bodies = [
            Body(f"block_{i}", "block", np.full(3, BLOCK_SIZE), c)
            for i, c in enumerate(self.grid(full_site))
        ]
        bodies += [cover_on("cover_0", full_site, g), cover_on("cover_1", empty_site, g)]
        goals = [Goal(f"goal_{i}", "block", c) for i, c in enumerate(self.grid(empty_site))]
        goals += [
            lid_goal("lid_goal_0", full_site, g),
            lid_goal("lid_goal_1", empty_site, g),
            storage_goal("storage_0", store_a, g),
            storage_goal("storage_1", store_b, g),
        ]
        return Layout(
            bodies,
            goals,
            [box_at("box_0", full_site, g), box_at("box_1", empty_site, g)],
            {"storage_0", "storage_1"},
            partially_observable=True,
        )
