"""What the dishwasher world looks like as a ``Scene``: dishes, slots and racks."""

from __future__ import annotations

import math

from manigraph_dishwasher.fixtures import Rack
from manigraph_dishwasher.sim.dishwasher_world import DishwasherWorld
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
)
from manigraph_shared.orientations import orientation
from manigraph_sim.world_model import vector


def about_vertical(yaw: float, q: Quaternion) -> Quaternion:
    """``q`` turned by ``yaw`` radians about the world's vertical (``q`` itself at 0)."""
    if yaw == 0.0:
        return q
    c, s = math.cos(yaw / 2), math.sin(yaw / 2)  # (0, 0, s, c) * q
    return Quaternion(
        x=c * q.x - s * q.y,
        y=c * q.y + s * q.x,
        z=c * q.z + s * q.w,
        w=c * q.w - s * q.z,
    )


def dishwasher_scene(
    world: DishwasherWorld, episode_id: str, stamp: float, sequence: int, ended: bool
) -> Scene:
    """Every dish (``filled``: it stands in a slot of its kind as the slot asks; one that
    stands the wrong way round is still to load, in another slot; its orientation the
    discrete one turned by its yaw, as a camera would see it), every slot (its rack,
    the orientation a dish must have in it; ``filled``: a dish is in it) and both racks with
    their open flag."""
    objects = [
        SceneObject(
            id=dish.id,
            category=ObjectCategory(dish.kind),
            position=vector(dish.position),
            orientation=about_vertical(dish.yaw, orientation(dish.orientation)),
            size=vector(dish.size),
            filled=world.stands_as_asked(dish),
        )
        for dish in world.dishes.values()
    ]
    goals = [
        SceneGoal(
            id=slot.id,
            category=GoalCategory(slot.kind),
            position=vector(world.slot_position(slot)),
            orientation=orientation(slot.orientation),
            filled=world.occupant(slot.id) is not None,
            fixture=slot.rack,
        )
        for slot in world.slots.values()
    ]
    racks = [
        Rack(
            id=rack.id,
            position=vector(rack.handle),
            open=rack.open,
            travel=rack.travel,
            rail=rack.rail,
        ).fixture()
        for rack in world.racks.values()
    ]
    return Scene(
        episode_id=episode_id,
        stamp=stamp,
        sequence=sequence,
        objects=objects,
        goals=goals,
        fixtures=racks,
        episode_ended=ended,
    )
