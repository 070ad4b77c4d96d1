"""The geometry of the box tasks' boxes, covers, block grid and sites, as one parameter.

The default is the geometric world's (and the demonstrations'): a 14 cm box holding a 3 x 3
grid of 4 cm blocks 4.5 cm apart, sites at least 20 cm apart anywhere in the task workspace.
A world with real fingers needs more room between blocks (see
``manigraph_blocks.sim.physics_boxes``) and passes its own geometry; the layouts keep their
structure (ids, grid order, which goals are optional), only the distances change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.errors import TaskError
from manigraph_sim.world_model import WORKSPACE_X, WORKSPACE_Y


@dataclass(frozen=True)
class BoxGeometry:
    """Metres. ``pitch`` is the block grid's spacing along (x, y). Sites (boxes, stacks,
    storage places) are at least ``site_distance`` apart, by Euclidean distance or, with
    ``square_sites``, along x or y (square footprints of that side never overlap)."""

    inner: float = 0.14  # inner side of the square box
    wall: float = 0.01
    height: float = 0.06  # rim height above the table
    cover_thickness: float = 0.01
    pitch: tuple[float, float] = (0.045, 0.045)
    site_distance: float = 0.2
    square_sites: bool = False
    site_x: tuple[float, float] = WORKSPACE_X
    site_y: tuple[float, float] = WORKSPACE_Y
    max_blocks: int = 9  # one box layer: the 3 x 3 grid

    def __post_init__(self) -> None:
        for name in ("inner", "wall", "height", "cover_thickness", "site_distance"):
            if not 0 < getattr(self, name) <= 1.0:
                raise TaskError(f"box_geometry.{name}: {getattr(self, name)} not in (0, 1] m")
        if not all(0 < p <= self.inner / 2 for p in self.pitch):
            raise TaskError(f"box_geometry.pitch: {self.pitch} must be in (0, inner / 2]")
        for name in ("site_x", "site_y"):
            low, high = getattr(self, name)
            if not low < high:
                raise TaskError(f"box_geometry.{name}: lower bound {low} must be < upper {high}")
        if not 1 <= self.max_blocks <= 9:
            raise TaskError(f"box_geometry.max_blocks: {self.max_blocks} not in 1..9")

    @property
    def cover_size(self) -> np.ndarray:
        """A cover rests on the rim all round: the box's outer footprint, ``cover_thickness``
        thick."""
        outer = self.inner + 2 * self.wall
        return np.array([outer, outer, self.cover_thickness])

    @property
    def lid_height(self) -> float:
        """Centre height of a cover closing a box."""
        return self.height + self.cover_thickness / 2

    def grid(self, site: np.ndarray, count: int, block_size: float) -> list[np.ndarray]:
        """``count`` block centres inside a box at ``site``, centre first, then around it."""
        cells = [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)]
        cells.sort(key=lambda c: (abs(c[0]) + abs(c[1]), c))
        px, py = self.pitch
        return [
            np.array([site[0] + i * px, site[1] + j * py, block_size / 2]) for i, j in cells[:count]
        ]
