"""The dishwasher's scripted expert: what the five demonstrations of a preference show."""

from __future__ import annotations

import zlib

from manigraph_dishwasher.fixtures import TOGGLE, TRAY_RACKS, TrayAction, racks
from manigraph_dishwasher.preference import Preference, allows, preferred_rack
from manigraph_planner.policies.base import Decision, Policy, register_policy
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
)
from manigraph_shared.orientations import nearest_orientation, up_axis_orientation

TOP, BOTTOM = TRAY_RACKS[TrayAction.TOGGLE_TOP], TRAY_RACKS[TrayAction.TOGGLE_BOTTOM]
_DISHES = (ObjectCategory.PLATE, ObjectCategory.BOWL)
#: Slots nearer than this (metres, on every axis) to a dish hold it: the geometric world puts
#: a dish exactly at its slot, a physical dish settles a few millimetres off (the physics
#: world's ``SLOT_FIT``); neighbouring slots are 5.5 cm apart.
_IN_SLOT = 0.02


def preferred(preference: str, dish: ObjectCategory, slot: SceneGoal) -> bool:
    """Whether ``preference`` lets ``dish`` stand in ``slot`` (the sim's rule,
    :func:`~manigraph_dishwasher.preference.allows`, read off the scene: a slot's rack, its
    category, and its side, left being y < 0)."""
    return allows(
        Preference(preference), dish.value, slot.category.value, slot.fixture, slot.position.y < 0
    )


class DishwasherExpert(Policy):
    """Loads the top rack first (the bottom one is loaded only with the top one in):

    1. while a dish whose preferred rack is the top one is not loaded as preferred: pull the
       top rack out if it is in, else put the dish with the smallest id into a free preferred
       slot (:meth:`_free_slot`), in that slot's orientation;
    2. push the top rack in;
    3. the same for the bottom rack, then push it in. Then there is nothing left to do.
    """

    preference: Preference

    def decide(self, scene: Scene) -> Decision | None:
        by_id = {rack.id: rack for rack in racks(scene)}
        if TOP not in by_id or BOTTOM not in by_id:
            return None
        pending = {TOP: [], BOTTOM: []}  # type: dict[str, list[SceneObject]]
        for dish in sorted(scene.objects, key=lambda o: o.id):
            if dish.category not in _DISHES or self._loaded(scene, dish):
                continue
            pending[self._rack_for(dish.category)].append(dish)
        for rack_id in (TOP, BOTTOM):
            rack = by_id[rack_id]
            if pending[rack_id]:
                if not rack.open:
                    return self._toggle(rack_id)
                dish = pending[rack_id][0]
                slot = self._free_slot(scene, dish)
                if slot is None:
                    return None
                return Decision(dish.id, slot.id, nearest_orientation(slot.orientation))
            if rack.open:
                return self._toggle(rack_id)
        return None

    def _rack_for(self, dish: ObjectCategory) -> str:
        return preferred_rack(self.preference, dish.value)

    def _loaded(self, scene: Scene, dish: SceneObject) -> bool:
        for slot in scene.goals:
            if slot.category is GoalCategory.BLOCK or slot.category is GoalCategory.COVER:
                continue
            gap = max(
                abs(a - b)
                for a, b in zip(slot.position.as_tuple(), dish.position.as_tuple(), strict=True)
            )
            if gap < _IN_SLOT:
                return preferred(self.preference, dish.category, slot) and up_axis_orientation(
                    dish.orientation
                ) == nearest_orientation(slot.orientation)
        return False

    def _free_slot(self, scene: Scene, dish: SceneObject) -> SceneGoal | None:
        """A free preferred slot, drawn by a hash of episode, dish and slot: deterministic,
        yet over demonstrations every slot is shown, so a policy learns 'any free slot on
        the preferred rack and side' rather than one slot order it cannot extend."""
        free = [
            g for g in scene.goals if not g.filled and preferred(self.preference, dish.category, g)
        ]
        key = f"{scene.episode_id}/{dish.id}/"
        return min(free, key=lambda g: (zlib.crc32((key + g.id).encode()), g.id)) if free else None

    @staticmethod
    def _toggle(rack_id: str) -> Decision:
        return Decision(rack_id, rack_id, None, TOGGLE)


@register_policy("dishwasher-top-bottom")
class TopBottomExpert(DishwasherExpert):
    """The expert for bowls in the top rack, plates in the bottom rack."""

    preference = Preference.TOP_BOTTOM


@register_policy("dishwasher-left-right")
class LeftRightExpert(DishwasherExpert):
    """The expert for everything on top: bowls on the right, plates on the left."""

    preference = Preference.LEFT_RIGHT


def dishwasher_expert(preference: str) -> DishwasherExpert:
    """The expert of ``preference`` (``top-bottom`` or ``left-right``)."""
    return TopBottomExpert() if preference == Preference.TOP_BOTTOM else LeftRightExpert()
