"""A shelf episode's layout: the generic bodies and goals, with the shelf they stand in."""

from __future__ import annotations

from dataclasses import dataclass, field

from manigraph_shelf.shelf_geometry import ShelfGeometry, Slot
from manigraph_sim.world_model import Layout


@dataclass
class ShelfLayout(Layout):
    """``goals`` are the ``slots`` (one goal per slot, the same ids), in ``geometry``'s
    cupboard."""

    geometry: ShelfGeometry = field(default_factory=ShelfGeometry)
    slots: list[Slot] = field(default_factory=list)
