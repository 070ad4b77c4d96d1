"""The dishwasher's loading rules read off a ``Scene``, for a robot whose world refuses
nothing by itself (``RobotDriver.checks_dish_rules``): the rules are the geometric world's
(``manigraph_shared.dishwasher_rules``), the state comes from the scene's racks and slots."""

from __future__ import annotations

import numpy as np

from manigraph_shared.dishwasher_rules import check_rack_usable, check_slot
from manigraph_shared.messages import Scene, SceneGoal, SceneObject

#: A dish this close to a slot's position stands in it (the physics world's ``SLOT_FIT``).
SLOT_FIT = 0.02


def _distance(a: SceneObject | SceneGoal, b: SceneObject | SceneGoal) -> float:
    return float(np.linalg.norm(np.subtract(a.position.as_tuple(), b.position.as_tuple())))


def slot_of(scene: Scene, dish: SceneObject) -> SceneGoal | None:
    """The slot ``dish`` stands in, if any."""
    if not dish.filled:
        return None
    slots = [g for g in scene.goals if g.rack is not None and _distance(g, dish) <= SLOT_FIT]
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
    open_racks = {rack.id: rack.open for rack in scene.racks}
    here = slot_of(scene, dish)
    if here is not None and here.rack is not None:
        check_rack_usable(here.rack, open_racks)
    if goal.rack is None:
        return
    check_rack_usable(goal.rack, open_racks)
    check_slot(goal.id, goal.category.value, dish.id, dish.category.value, occupant(scene, goal))
