"""The dishwasher's loading rules (docs/dishwasher.md), written once for its sim, planner and
skills parts: the geometric world refuses an action with them, the skills check them on the
``Scene`` (:func:`check_dish_move`) for a robot whose world does not refuse anything by itself
(``RobotDriver.checks_family_rules``: the physics world, a real dishwasher), the state read off
the scene's racks and slots, and the learned policy keeps to the racks they let be loaded
(:func:`rack_usable`). A common module of the package: it imports no service.

Each check raises a ``SkillError`` whose reason names the rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final

import numpy as np

from manigraph_dishwasher.fixtures import racks
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Scene, SceneGoal, SceneObject

TOP_RACK: Final = "rack_top"
BOTTOM_RACK: Final = "rack_bottom"
#: A dish counts as standing in a slot when its centre is this close to the slot's position
#: (with the rack where it physically is) and it is not held: half a plate's slot pitch,
#: metres. The physics world's test, and the skills' reading of a ``Scene``.
SLOT_FIT: Final = 0.02


def is_dishwasher_scene(scene: Scene) -> bool:
    """A dishwasher scene shows its racks (the trays the expert opens and closes): how the
    planner and the skills tell this family's scenes from another's."""
    return bool(racks(scene))


def rack_refusal(rack_id: str, open_racks: Mapping[str, bool]) -> SkillError | None:
    """The rack rule: a rack is loaded (or unloaded) only when pulled out (``rack_closed``);
    the bottom one only while the top one is pushed in (``top_rack_open``): the open top rack
    is in the way. ``open_racks``: every rack's open flag (a rack left out: pushed in). The
    refusal naming the rule, or None: the rack can be loaded now."""
    if not open_racks.get(rack_id, False):
        return SkillError("rack_closed", f"{rack_id} is pushed in")
    if rack_id == BOTTOM_RACK and open_racks.get(TOP_RACK, False):
        return SkillError("top_rack_open", "the bottom rack is loaded only with the top one in")
    return None


def rack_usable(rack_id: str, open_racks: Mapping[str, bool]) -> bool:
    """Whether rack ``rack_id`` can be loaded now (:func:`rack_refusal`)."""
    return rack_refusal(rack_id, open_racks) is None


def check_rack_usable(rack_id: str, open_racks: Mapping[str, bool]) -> None:
    """Raise the rack rule's refusal (:func:`rack_refusal`), if any."""
    refusal = rack_refusal(rack_id, open_racks)
    if refusal is not None:
        raise refusal


def check_slot(
    slot_id: str, slot_kind: str, dish_id: str, dish_kind: str, occupant: str | None
) -> None:
    """A slot holds one dish (``slot_taken``) of its own kind (``wrong_slot``); ``occupant``
    is the dish in it now, if any."""
    if occupant is not None and occupant != dish_id:
        raise SkillError("slot_taken", f"{slot_id} holds {occupant}")
    if slot_kind != dish_kind:
        raise SkillError("wrong_slot", f"{slot_id} takes a {slot_kind}, not a {dish_kind}")


def _distance(a: SceneObject | SceneGoal, b: SceneObject | SceneGoal) -> float:
    return float(np.linalg.norm(np.subtract(a.position.as_tuple(), b.position.as_tuple())))


def slot_of(scene: Scene, dish: SceneObject) -> SceneGoal | None:
    """The slot ``dish`` stands in, if any."""
    if not dish.filled:
        return None
    slots = [g for g in scene.goals if g.fixture is not None and _distance(g, dish) <= SLOT_FIT]
    return min(slots, key=lambda g: _distance(g, dish), default=None)


def occupant(scene: Scene, slot: SceneGoal) -> str | None:
    """The dish standing in ``slot``, if any."""
    if not slot.filled:
        return None
    dishes = [o for o in scene.objects if o.filled and _distance(o, slot) <= SLOT_FIT]
    return min(dishes, key=lambda o: _distance(o, slot)).id if dishes else "another dish"


def check_dish_move(scene: Scene, dish: SceneObject, goal: SceneGoal) -> None:
    """Raise ``SkillError`` naming the rule if moving ``dish`` to ``goal`` breaks one, in the
    geometric world's order: taking it out of its rack, putting it into the goal's rack, the
    goal slot taken, the goal slot of another kind."""
    open_racks = {rack.id: rack.open for rack in racks(scene)}
    here = slot_of(scene, dish)
    if here is not None and here.fixture is not None:
        check_rack_usable(here.fixture, open_racks)
    if goal.fixture is None:
        return
    check_rack_usable(goal.fixture, open_racks)
    check_slot(goal.id, goal.category.value, dish.id, dish.category.value, occupant(scene, goal))
