"""What the arm must not touch, read off the scene: blocks, covers, towers and box walls.

Every visible object is a box of its size at its pose, except the one being moved (it is
between the fingers). Objects that *support* the grasp or the goal (directly under the moved
object, or under the goal it is set down on) are marked: the hand and fingers may come close
to them, the arm links may not. Boxes are not scene objects: a cover goal marks where a
box's lid sits, so the box is four walls under it, of the footprint of the covers seen in the
scene (``WALL`` thick, from the table up to the lid's underside). The table is the collision
model's own (``motion.collision``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.grasp_points import (
    RACK_FLOOR_HALF_Y,
    RACK_FLOOR_THICKNESS,
    RACK_FLOOR_TOP,
    RACK_FLOOR_X,
    RACK_HANDLE_X,
    rack_handle_boxes,
)
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneObject

#: Assumed box wall thickness, metres (the physics world's boxes: 1 cm).
WALL = 0.01
#: An object counts as a support when its top is within this of the underside above it.
SUPPORT_GAP = 0.01


@dataclass(frozen=True)
class Obstacle:
    """A box-shaped obstacle in the robot base frame."""

    id: str
    centre: tuple[float, float, float]  # metres
    size: tuple[float, float, float]  # full extents, metres
    quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # x, y, z, w
    support: bool = False  # under the moved object or its goal: the hand may touch it


def scene_obstacles(scene: Scene, moving: SceneObject, at: np.ndarray) -> tuple[Obstacle, ...]:
    """The obstacles for moving ``moving`` whose centre is (or will be) at ``at``."""
    bottom = at[2] - moving.size.z / 2
    half = np.array(moving.size.as_tuple()[:2]) / 2
    found: list[Obstacle] = []
    for other in scene.objects:
        if other.id == moving.id or not other.visible:
            continue
        centre = np.array(other.position.as_tuple())
        size = np.array(other.size.as_tuple())
        top = centre[2] + size[2] / 2
        overlaps = bool(np.all(np.abs(centre[:2] - at[:2]) < half + size[:2] / 2))
        support = overlaps and abs(top - bottom) <= SUPPORT_GAP
        o = other.orientation
        found.append(
            Obstacle(
                other.id,
                tuple(centre.tolist()),
                tuple(size.tolist()),
                (o.x, o.y, o.z, o.w),
                support,
            )
        )
    found.extend(box_walls(scene))
    found.extend(rack_obstacles(scene, moving, at))
    return tuple(found)


def rack_obstacles(
    scene: Scene, moving: SceneObject | None = None, at: np.ndarray | None = None
) -> list[Obstacle]:
    """The floor and the handle (``grasp_points.rack_handle_boxes``) of every dishwasher
    rack, where it is. The floor: pulled out, it reaches over the
    counter's far row, where a hand lifting a dish would meet it; pushed in, the top rack's
    front edge is over the pulled-out bottom rack's far slots, where the wrist reaching into
    them met it (and stopped 5 cm short: the bowl it held fell off the rack). The slots' ribs
    and the dishes in them are not floors. A floor under ``at``, where ``moving`` is set down
    (a slot of that rack: within the floor's footprint, no higher above it than the dish's
    largest half extent, whichever way up it stands), is a support, like a block under a
    goal: the fingers may come close to it."""
    found = []
    for rack in scene.racks:
        centre = np.array(rack.position.as_tuple()) - np.array([RACK_HANDLE_X, 0.0, 0.0])
        bottom = RACK_FLOOR_TOP - RACK_FLOOR_THICKNESS
        low = centre + np.array([RACK_FLOOR_X[0], -RACK_FLOOR_HALF_Y, bottom])
        high = centre + np.array([RACK_FLOOR_X[1], RACK_FLOOR_HALF_Y, RACK_FLOOR_TOP])
        support = False
        if moving is not None and at is not None:
            reach = max(moving.size.as_tuple()) / 2 + SUPPORT_GAP
            above = at[2] - high[2]
            support = bool(
                np.all((at[:2] >= low[:2]) & (at[:2] <= high[:2])) and 0 <= above <= reach
            )
        middle = tuple(((low + high) / 2).tolist())
        size = tuple((high - low).tolist())
        found.append(Obstacle(f"{rack.id}:floor", middle, size, support=support))
        for number, (low, high) in enumerate(rack_handle_boxes(rack.id)):
            part = "handle" if number == 0 else "handle_bar"
            middle = tuple((centre + (low + high) / 2).tolist())
            found.append(Obstacle(f"{rack.id}:{part}", middle, tuple((high - low).tolist())))
    return found


def box_walls(scene: Scene) -> list[Obstacle]:
    """Four walls under every cover goal, sized like the scene's covers."""
    covers = [o for o in scene.objects if o.category is ObjectCategory.COVER]
    if not covers:
        return []
    side_x = max(c.size.x for c in covers)
    side_y = max(c.size.y for c in covers)
    thickness = max(c.size.z for c in covers)
    walls: list[Obstacle] = []
    for goal in scene.goals:
        if goal.category is not GoalCategory.COVER:
            continue
        x, y, z = goal.position.as_tuple()
        height = z - thickness / 2
        if height <= 0:
            continue
        mid = height / 2
        for side, (dx, dy, sx, sy) in {
            "x-": (-(side_x - WALL) / 2, 0.0, WALL, side_y),
            "x+": ((side_x - WALL) / 2, 0.0, WALL, side_y),
            "y-": (0.0, -(side_y - WALL) / 2, side_x, WALL),
            "y+": (0.0, (side_y - WALL) / 2, side_x, WALL),
        }.items():
            walls.append(Obstacle(f"{goal.id}:wall{side}", (x + dx, y + dy, mid), (sx, sy, height)))
    return walls
