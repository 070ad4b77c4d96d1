"""The shelf world with honest bookkeeping and no dynamics.

A block lies on the table or stands in a slot. Picking takes any block that is not behind a
filled front slot; placing sets the held block at the slot its target is within the goal
tolerance of. The shelf's rule (:func:`~manigraph_shelf.shelf_geometry.blocked`): a back slot
whose front slot is filled cannot be reached, so a place into it fails and the block stays
where it was, as does a place into a filled slot or onto the shelf off its slots; each is a
``SkillError`` naming why, as other worlds refuse an impossible action. A place outside the
shelf sets the block down on the table there.
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shelf.shelf_geometry import OBJECT_SIZE, Slot, blocked
from manigraph_shelf.sim.layout import ShelfLayout


class ShelfWorld:
    """The blocks of ``layout`` and which slot each stands in."""

    def __init__(self, layout: ShelfLayout, goal_tolerance: float = 0.01) -> None:
        self.geometry = layout.geometry
        self.slots = list(layout.slots)
        self.positions = {body.id: body.position.copy() for body in layout.bodies}
        self.goal_tolerance = goal_tolerance
        #: Slot id -> the block standing in it.
        self.occupant: dict[str, str] = {}
        self.held: str | None = None

    def filled(self) -> set[str]:
        """The ids of the slots holding a block."""
        return set(self.occupant)

    def slot_of(self, body_id: str) -> Slot | None:
        """The slot ``body_id`` stands in, if any."""
        return next((s for s in self.slots if self.occupant.get(s.id) == body_id), None)

    def pick(self, body_id: str) -> None:
        """Take ``body_id`` into the gripper; a block behind a filled front slot is out of
        reach (``SkillError`` ``slot_blocked``)."""
        if self.held is not None:
            raise SkillError("gripper_full", f"already holding {self.held}")
        if body_id not in self.positions:
            raise SkillError("unknown_object", body_id)
        slot = self.slot_of(body_id)
        if slot is not None and blocked(slot, self.filled(), self.slots):
            raise SkillError("slot_blocked", f"{body_id} stands behind a filled front slot")
        self.held = body_id

    def place(self, body_id: str, target: np.ndarray) -> None:
        """Set the held ``body_id`` down at ``target``: into the slot there, or on the table
        in front of the shelf. A place the shelf refuses leaves the block where it was
        (``SkillError``: ``slot_blocked``, ``slot_filled``, ``off_slot``)."""
        if self.held != body_id:
            raise SkillError("not_holding", f"not holding {body_id}")
        self.held = None  # set down, or back where it was
        slot = self.slot_at(target)
        if slot is None:
            if target[0] >= self.geometry.front_x:
                raise SkillError("off_slot", f"{target.round(3).tolist()} is in no slot")
            self._leave_slot(body_id)
            self.positions[body_id] = np.array([target[0], target[1], OBJECT_SIZE / 2])
            return
        if self.occupant.get(slot.id, body_id) != body_id:
            raise SkillError("slot_filled", f"{slot.id} holds {self.occupant[slot.id]}")
        own = self.slot_of(body_id)  # lifted out of it: it no longer blocks anything
        if blocked(slot, self.filled() - {own.id if own else ""}, self.slots):
            raise SkillError("slot_blocked", f"the front slot before {slot.id} is filled")
        self._leave_slot(body_id)
        self.occupant[slot.id] = body_id
        self.positions[body_id] = np.array(slot.position)

    def slot_at(self, target: np.ndarray) -> Slot | None:
        """The slot whose position ``target`` is within the goal tolerance of, if any."""
        for slot in self.slots:
            if np.linalg.norm(np.array(slot.position) - target) <= self.goal_tolerance:
                return slot
        return None

    def _leave_slot(self, body_id: str) -> None:
        slot = self.slot_of(body_id)
        if slot is not None:
            del self.occupant[slot.id]
