"""What a dishwasher episode is made of: dishes, racks, slots and the loading preference.

Plain records laid out by the ``dishwasher`` task and played by
:class:`~manigraph_dishwasher.sim.dishwasher_world.DishwasherWorld`; they build on
the sim's ground floor (``world_model``) and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

import numpy as np

from manigraph_dishwasher.preference import BOWL, PLATE, Preference, allows
from manigraph_dishwasher.rack_geometry import RACK_HANDLE_X
from manigraph_dishwasher.rack_geometry import RACK_TRAVEL as RACK_PULL
from manigraph_dishwasher.rules import BOTTOM_RACK, TOP_RACK
from manigraph_shared.errors import TaskError
from manigraph_shared.orientations import UPRIGHT, UPSIDE_DOWN
from manigraph_sim.world_model import Layout

#: Full extents of each dish in its own frame (x, y, z), metres: a plate is flat, a bowl deep.
DISH_SIZE: Final = {PLATE: (0.08, 0.08, 0.015), BOWL: (0.06, 0.06, 0.035)}
#: The orientation a dish must have in its slot (``manigraph_shared.orientations``).
SLOT_ORIENTATION: Final = {PLATE: UPRIGHT, BOWL: UPSIDE_DOWN}

TOP: Final = TOP_RACK
BOTTOM: Final = BOTTOM_RACK
#: How far a rack slides out towards the robot (-x), metres.
RACK_TRAVEL: Final = RACK_PULL
#: Slots per row of a rack: a plate row and a bowl row, half of each left (y < 0).
SLOTS_PER_ROW: Final = 12
SLOT_PITCH: Final = 0.055
#: A rack's handle (the position a Scene reports for it) relative to its centre along x.
HANDLE_X: Final = RACK_HANDLE_X
#: Most dishes an episode may hold: every preference must have a slot for each.
MAX_DISHES: Final = SLOTS_PER_ROW


@dataclass
class Dish:
    id: str
    kind: str  # PLATE | BOWL
    position: np.ndarray  # centre, metres
    orientation: int  # index into manigraph_shared.orientations
    slot: str | None = None  # the slot it stands in, if any
    #: Its own extents (the physics world's dishes), else the kind's ``DISH_SIZE``.
    extents: tuple[float, float, float] | None = None
    #: How far it is turned about the vertical from its discrete orientation, radians: a
    #: physics world measures it (a dish let go of sideways comes to rest turned), the
    #: geometric world's dishes are square to the axes (0).
    yaw: float = 0.0

    @property
    def size(self) -> np.ndarray:
        return np.array(self.extents or DISH_SIZE[self.kind])


@dataclass
class Rack:
    id: str
    #: Centre of the closed rack (x, y, z); open, it is ``RACK_TRAVEL`` nearer the robot.
    closed_centre: np.ndarray
    open: bool = False
    #: How far it is out, metres, where a physics world measured it (a rack a placement
    #: nudged part of the way in); None: all the way if open, else not at all.
    travel: float | None = None
    #: How far its rail lets it out, metres, where a world's differs (None: ``RACK_TRAVEL``).
    rail: float | None = None

    @property
    def centre(self) -> np.ndarray:
        travel = self.travel if self.travel is not None else RACK_TRAVEL if self.open else 0.0
        return self.closed_centre - np.array([travel, 0.0, 0.0])

    @property
    def handle(self) -> np.ndarray:
        return self.centre + np.array([HANDLE_X, 0.0, 0.0])


@dataclass
class Slot:
    id: str
    rack: str
    kind: str  # which dish it takes
    offset: np.ndarray  # dish centre relative to the rack centre, metres

    @property
    def orientation(self) -> int:
        return SLOT_ORIENTATION[self.kind]


@dataclass
class DishwasherLayout(Layout):
    """A dishwasher episode. ``bodies`` and ``goals`` mirror the dishes and slots as laid out;
    no goal is required as such: success is the preference's (see the task)."""

    dishes: list[Dish] = field(default_factory=list)
    racks: list[Rack] = field(default_factory=list)
    slots: list[Slot] = field(default_factory=list)
    preference: Preference = Preference.TOP_BOTTOM

    def required_goals(self) -> set[str]:
        return set()

    def validate(self) -> None:
        names = (
            [d.id for d in self.dishes] + [r.id for r in self.racks] + [s.id for s in self.slots]
        )
        if len(names) != len(set(names)):
            raise TaskError("layout: dish, rack and slot ids must be unique")
        if not self.dishes:
            raise TaskError("objects: at least one dish")


def allowed(preference: Preference, dish_kind: str, slot: Slot) -> bool:
    """Whether ``preference`` lets a ``dish_kind`` stand in ``slot``
    (:func:`~manigraph_dishwasher.preference.allows`; a slot's side is its offset's, left
    being y < 0 of its rack's centre)."""
    return allows(preference, dish_kind, slot.kind, slot.rack, float(slot.offset[1]) < 0)
