"""Shelf filling: blocks from the table onto the boards of a shelf, back slots first."""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import ConfigError, TaskError
from manigraph_shelf.shelf_geometry import (
    OBJECT_SIZE,
    ROW_ATTRIBUTE,
    START_JITTER,
    geometry_for,
    levels_for,
    slots_for,
    start_cells,
)
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.options import ShelfTask
from manigraph_sim.tasks.base import register_task
from manigraph_sim.world_model import BLOCK, Body, Goal

#: Objects when the request sets none.
DEFAULT_OBJECTS = 4


def start_positions(rng: np.random.Generator, count: int) -> list[np.ndarray]:
    """``count`` object centres on the table in front of the shelf: random cells of the
    start grid, jittered."""
    cells = start_cells()
    if count > len(cells):
        raise TaskError(f"objects: {count} blocks do not fit on the table ({len(cells)} cells)")
    chosen = rng.choice(len(cells), size=count, replace=False)
    return [
        np.array(
            [
                *np.array(cells[int(c)]) + rng.uniform(-START_JITTER, START_JITTER, 2),
                OBJECT_SIZE / 2,
            ]
        )
        for c in chosen
    ]


@register_task("shelf")
class ShelfFilling(ShelfTask):
    """Shelf filling.

    **Task Description**: ``objects`` blocks (4 cm) lie on the table in front of a shelf whose
    open side faces the robot; put one into each slot of its boards. Each column of a board
    has a back slot and a front slot; an object is placed from the front, under the board
    above, so a filled front slot blocks the way to the back slot behind it: fill the back
    one first. ``objects`` / 2 columns fill levels of up to three columns, bottom first.

    **Randomizations**: the blocks' start positions on the table: random cells of an 8 cm
    grid, jittered by up to 1 cm.

    **Success Conditions**: every slot holds a block.
    """

    def validate(self) -> None:
        try:
            levels_for(self.objects)
        except ConfigError as exc:
            raise TaskError(f"objects: {exc.problem}") from None

    @property
    def objects(self) -> int:
        objects = self.params.objects
        return DEFAULT_OBJECTS if objects is None else objects

    def layout(self, rng: np.random.Generator) -> ShelfLayout:
        geometry = geometry_for(self.objects)
        slots = slots_for(self.objects, geometry)
        size = np.full(3, OBJECT_SIZE)
        bodies = [
            Body(f"block_{i}", BLOCK, size.copy(), site)
            for i, site in enumerate(start_positions(rng, self.objects))
        ]
        goals = [
            Goal(slot.id, BLOCK, np.array(slot.position), attributes={ROW_ATTRIBUTE: slot.row})
            for slot in slots
        ]
        return ShelfLayout(bodies=bodies, goals=goals, geometry=geometry, slots=slots)

    def max_steps(self, goals: int) -> int:
        """One pick per slot, doubled, and four to spare."""
        return 2 * goals + 4
