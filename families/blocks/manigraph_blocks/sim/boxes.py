"""Box packing, unpacking and rearrangement: boxes with covers that must be lifted off."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from manigraph_blocks.sim.box_geometry import BoxGeometry
from manigraph_blocks.sim.options import BlockTask
from manigraph_blocks.sim.placement import (
    sample_sites,
    sample_square_sites,
    stack_bodies,
    stack_goals,
)
from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import register_task
from manigraph_sim.world_model import BLOCK_SIZE, Body, Container, Goal, Layout


def footprints_apart(sites: Sequence[np.ndarray], side: float) -> bool:
    """No two squares of ``side`` centred on ``sites`` overlap."""
    return all(
        float(np.abs(a - b).max()) >= side for i, a in enumerate(sites) for b in sites[i + 1 :]
    )


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


class BoxTask(BlockTask):
    """The box tasks share a geometry (``BlockOptions.boxes``) and how they place sites."""

    @property
    def geometry(self) -> BoxGeometry:
        return self.params.boxes or BoxGeometry()

    def validate(self) -> None:
        if self.params.stacks != 1:
            raise TaskError(f"stacks: {self.name} has one stack of blocks")
        most = self.geometry.max_blocks
        if not 1 <= self.params.blocks <= most:
            raise TaskError(f"blocks: must be in 1..{most} (one box layer)")

    def sites(self, rng: np.random.Generator, wide: Sequence[bool]) -> list[np.ndarray]:
        """One table site per entry of ``wide``, ``site_distance`` apart. Sites marked wide
        (a box, or a storage place for its cover) hold a cover's footprint, and no two of
        those overlap: a cover put down in its storage place lies on the table, not on the
        rim of a box. (Sites 20 cm apart can still be 15 cm apart along both x and y, where
        two 16 cm footprints overlap; such draws are redrawn from the same stream, so every
        other layout stays as it was.)"""
        g = self.geometry
        area = (g.site_x, g.site_y)
        for _ in range(1000):
            if g.square_sites:
                sites = sample_square_sites(rng, len(wide), g.site_distance, area)
            else:
                sites = sample_sites(rng, len(wide), g.site_distance, area)
            footprints = [site for site, is_wide in zip(sites, wide, strict=True) if is_wide]
            if footprints_apart(footprints, float(g.cover_size[0])):
                return sites
        raise TaskError(f"cannot fit {sum(wide)} box footprints apart in the workspace")

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
        box_site, stack_site, store_site = self.sites(rng, (True, False, True))
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
        box_site, stack_site, store_site = self.sites(rng, (True, False, True))
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
        full_site, empty_site, store_a, store_b = self.sites(rng, (True,) * 4)
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
