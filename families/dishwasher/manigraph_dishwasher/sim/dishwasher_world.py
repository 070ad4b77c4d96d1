"""The dishwasher world: dishes on a counter, two racks that slide out and in, and the paper's
loading rules, with honest bookkeeping and no dynamics.

Rules (each refusal is a ``SkillError`` whose reason names it):

* a dish is put into a slot only while the slot's rack is pulled out (``rack_closed``);
* the bottom rack is loaded (or unloaded) only while the top rack is pushed in
  (``top_rack_open``): the open top rack is in the way;
* a slot holds one dish (``slot_taken``) of its own kind (``wrong_slot``);
* a rack is toggled with an empty gripper (``gripper_full``).

A refused place leaves the dish where it was picked from, so a bad decision costs a step but
never breaks the episode. A dish released away from every slot lands on the counter.
"""

from __future__ import annotations

import numpy as np

from manigraph_dishwasher.rules import check_rack_usable, check_slot
from manigraph_dishwasher.sim.model import (
    Dish,
    DishwasherLayout,
    Preference,
    Rack,
    Slot,
    allowed,
)
from manigraph_shared.errors import SkillError

#: How far (metres) a release may be from a slot's dish position and still go into it.
SLOT_TOLERANCE = 0.01


def resting_height(dish: Dish) -> float:
    """Centre height of ``dish`` lying on the counter (z = 0) in its orientation."""
    up_axis = (2, 2, 1, 1, 0, 0)[dish.orientation]
    return float(dish.size[up_axis]) / 2


class DishwasherWorld:
    def __init__(self, layout: DishwasherLayout) -> None:
        self.preference: Preference = layout.preference
        self.dishes = {dish.id: dish for dish in layout.dishes}
        self.racks = {rack.id: rack for rack in layout.racks}
        self.slots = {slot.id: slot for slot in layout.slots}
        self.held: str | None = None

    # --- queries ----------------------------------------------------------------------------
    def slot_position(self, slot: Slot) -> np.ndarray:
        return self.racks[slot.rack].centre + slot.offset

    def occupant(self, slot_id: str) -> str | None:
        for dish in self.dishes.values():
            if dish.slot == slot_id:
                return dish.id
        return None

    def stands_as_asked(self, dish: Dish) -> bool:
        """In a slot, in the slot's orientation."""
        return dish.slot is not None and dish.orientation == self.slots[dish.slot].orientation

    def loaded_as_preferred(self, dish: Dish) -> bool:
        """In a slot the preference allows, in the slot's orientation."""
        if not self.stands_as_asked(dish):
            return False
        assert dish.slot is not None
        return allowed(self.preference, dish.kind, self.slots[dish.slot])

    def loaded(self) -> int:
        return sum(self.loaded_as_preferred(dish) for dish in self.dishes.values())

    def racks_closed(self) -> int:
        return sum(not rack.open for rack in self.racks.values())

    def done(self) -> bool:
        return self.loaded() == len(self.dishes) and self.racks_closed() == len(self.racks)

    # --- actions ----------------------------------------------------------------------------
    def _check_rack_usable(self, rack: Rack) -> None:
        check_rack_usable(rack.id, {r.id: r.open for r in self.racks.values()})

    def pick(self, dish_id: str) -> None:
        if self.held is not None:
            raise SkillError("gripper_full", f"already holding {self.held}")
        dish = self.dishes.get(dish_id)
        if dish is None:
            raise SkillError("unknown_object", dish_id)
        if dish.slot is not None:
            self._check_rack_usable(self.racks[self.slots[dish.slot].rack])
        self.held = dish_id

    def place(self, dish_id: str, target: np.ndarray, orientation: int) -> None:
        """Release the held dish at ``target`` in ``orientation``: into the slot there, or onto
        the counter. A refusal puts the dish back where it was and raises."""
        if self.held != dish_id:
            raise SkillError("not_holding", f"not holding {dish_id}")
        dish = self.dishes[dish_id]
        self.held = None  # from here on, a refusal leaves the dish where it was
        slot = self._slot_at(target)
        if slot is None:
            dish.slot = None
            dish.orientation = orientation
            dish.position = np.array([target[0], target[1], resting_height(dish)])
            return
        self._check_rack_usable(self.racks[slot.rack])
        check_slot(slot.id, slot.kind, dish_id, dish.kind, self.occupant(slot.id))
        dish.slot = slot.id
        dish.orientation = orientation
        dish.position = self.slot_position(slot)

    def toggle(self, rack_id: str) -> None:
        """Pull rack ``rack_id`` out, or push it in; the dishes in it travel along."""
        if self.held is not None:
            raise SkillError("gripper_full", f"holding {self.held}: cannot grasp a rack handle")
        rack = self.racks.get(rack_id)
        if rack is None:
            raise SkillError("unknown_rack", rack_id)
        rack.open = not rack.open
        for dish in self.dishes.values():
            if dish.slot is not None and self.slots[dish.slot].rack == rack_id:
                dish.position = self.slot_position(self.slots[dish.slot])

    def _slot_at(self, target: np.ndarray) -> Slot | None:
        for slot in self.slots.values():
            if np.linalg.norm(self.slot_position(slot) - target) <= SLOT_TOLERANCE:
                return slot
        return None
