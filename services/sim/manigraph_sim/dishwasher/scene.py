"""What the dishwasher world looks like as a ``Scene``: dishes, slots and racks."""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    SceneRack,
    Vector3,
)
from manigraph_shared.orientations import orientation
from manigraph_sim.dishwasher.world import DishwasherWorld


def _vector(values: np.ndarray) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def dishwasher_scene(
    world: DishwasherWorld, episode_id: str, stamp: float, sequence: int, ended: bool
) -> Scene:
    """Every dish (``filled``: it stands in a slot of its kind), every slot (its rack, the
    orientation a dish must have in it) and both racks with their open flag."""
    objects = [
        SceneObject(
            id=dish.id,
            category=ObjectCategory(dish.kind),
            position=_vector(dish.position),
            orientation=orientation(dish.orientation),
            size=_vector(dish.size),
            filled=dish.slot is not None,
        )
        for dish in world.dishes.values()
    ]
    goals = [
        SceneGoal(
            id=slot.id,
            category=GoalCategory(slot.kind),
            position=_vector(world.slot_position(slot)),
            orientation=orientation(slot.orientation),
            filled=world.occupant(slot.id) is not None,
            rack=slot.rack,
        )
        for slot in world.slots.values()
    ]
    racks = [
        SceneRack(id=rack.id, position=_vector(rack.handle), open=rack.open)
        for rack in world.racks.values()
    ]
    return Scene(
        episode_id=episode_id,
        stamp=stamp,
        sequence=sequence,
        objects=objects,
        goals=goals,
        racks=racks,
        episode_ended=ended,
    )
