"""How PickAndPlace holds an object, read off the scene: where, along which axis, how high.

* **Where**: a block at its centre, a cover at its handle (``grasp_points.grasp_height``).
* **Along which axis** the fingers close: the driver's default (the base frame's x) unless
  something stands within the open fingers' reach on that axis and the other axis has more
  room. "Something" is another visible object beside the grasp point, at the fingers' height,
  within their width across the closing axis. So a block in a box is taken between free
  sides (``manigraph_sim.physics.box_layout`` leaves room on one side of every cell it uses),
  and stacks and pyramid rows, which have room along x, are grasped as before.
* **Dishes**: a plate standing on an edge is taken across its thickness (``plate_turn``) and
  set into its slot with its thickness across y, between the slot's ribs; a bowl as a block.
* **How high to carry**: a cover sticks out far beyond the hand, so it is carried with its
  underside above every object's top and every goal (a box's rim is under its lid goal); a
  held block is carried the same way (its underside 2 cm over every top), and the empty hand
  to a block at the planner's own heights (the arm-link check sees the hand, not what it holds).
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.grasp_points import grasp_height
from manigraph_shared.messages import ObjectCategory, Scene, SceneObject, Vector3
from manigraph_shared.panda import (
    FINGER_ABOVE_TCP,
    FINGER_BELOW_TCP,
    FINGER_HALF_WIDTH,
    FINGER_OPEN,
    FINGER_REACH,
)
from manigraph_skills.drivers.base import Grasp
from manigraph_skills.obstacles import scene_obstacles
from manigraph_skills.turn_over import HORIZONTAL, rotation_of

#: Added to the fingers' reach before an axis counts as free, metres.
MARGIN = 0.005
#: Between a carried object's underside and what it passes over, metres.
CARRY_CLEARANCE = 0.02
#: Hand yaw that turns the closing axis from x to y.
TURN_TO_Y = -np.pi / 2


def room(scene: Scene, point: np.ndarray, axis: int, moving: str) -> float:
    """Free distance from ``point`` (the TCP) along ``axis`` (0: x, 1: y) to the nearest
    object the open fingers could hit, on either side; inf if none."""
    across = 1 - axis
    nearest = np.inf
    for other in scene.objects:
        if other.id == moving or not other.visible:
            continue
        centre = np.array(other.position.as_tuple())
        half = np.array(other.size.as_tuple()) / 2
        if not (
            centre[2] - half[2] < point[2] + FINGER_ABOVE_TCP
            and centre[2] + half[2] > point[2] - FINGER_BELOW_TCP
        ):
            continue  # above or below the fingers
        if abs(centre[across] - point[across]) >= FINGER_HALF_WIDTH + half[across]:
            continue  # beside the fingers
        gap = abs(centre[axis] - point[axis]) - half[axis]
        if gap > 0:  # (an object under or over the point is not beside it)
            nearest = min(nearest, gap)
    return nearest


def closing_turn(scene: Scene, point: np.ndarray, moving: str) -> float:
    """0 to close along x (the default), ``TURN_TO_Y`` to close along y."""
    room_x = room(scene, point, 0, moving)
    if room_x >= FINGER_REACH + MARGIN:
        return 0.0
    return TURN_TO_Y if room(scene, point, 1, moving) > room_x else 0.0


def carry_height(scene: Scene, item: SceneObject, height: float) -> float:
    """Lowest TCP height that carries ``item`` (held ``height`` above its centre) over
    everything; 0 (the planner's own carry heights) for an object no wider than the hand."""
    if max(item.size.x, item.size.y) <= 2 * FINGER_OPEN:
        return 0.0
    return clearing_height(scene, item, height)


def clearing_height(scene: Scene, item: SceneObject, height: float) -> float:
    """Lowest TCP height at which ``item`` (held ``height`` above its centre) passes over
    every other object's top and every goal with ``CARRY_CLEARANCE`` to spare."""
    tops = [o.position.z + o.size.z / 2 for o in scene.objects if o.id != item.id]
    tops += [g.position.z for g in scene.goals]
    hang = height + item.size.z / 2
    return max(tops, default=0.0) + hang + CARRY_CLEARANCE


def _point(position: Vector3, height: float) -> np.ndarray:
    return np.array(position.as_tuple()) + np.array([0.0, 0.0, height])


def plate_turn(item: SceneObject) -> float | None:
    """A plate is taken across its thickness: ``TURN_TO_Y`` if its thin axis lies along y,
    0 along x; None if it lies flat (wider than the fingers span that way)."""
    if item.category.value != "plate":
        return None
    thin = rotation_of(item.orientation)[:, 2]
    if abs(thin[2]) > HORIZONTAL:
        return None
    return TURN_TO_Y if abs(thin[1]) > abs(thin[0]) else 0.0


def choose_grasps(scene: Scene, item: SceneObject, goal: Vector3) -> tuple[Grasp, Grasp]:
    """The grasp to pick ``item`` with, and the one to set it down at ``goal`` with, each
    with the obstacles the arm must avoid on the way (``obstacles``)."""
    height = grasp_height(item.category.value, np.array(item.size.as_tuple()))
    carry = carry_height(scene, item, height)
    here, there = np.array(item.position.as_tuple()), np.array(goal.as_tuple())
    turn = plate_turn(item)
    if turn is not None:
        # Into its slot across y whichever way it was taken: the slot's ribs hold it so.
        return (
            Grasp(height, turn, carry, scene_obstacles(scene, item, here), np.pi),
            Grasp(height, TURN_TO_Y, carry, scene_obstacles(scene, item, there), np.pi),
        )
    pick = Grasp(
        height,
        closing_turn(scene, _point(item.position, height), item.id),
        carry,
        scene_obstacles(scene, item, here),
    )
    if item.category is ObjectCategory.BLOCK:
        # The planner carries at most ``PlanConfig.max_carry_z`` (0.30 m) high: a block lifted
        # off an eight-block tower (top 0.28 m once it is gone) would come down onto the tower
        # and drag across it. The arm check does not see the held block; this height does.
        carry = max(carry, clearing_height(scene, item, height))
    place = Grasp(
        height,
        closing_turn(scene, _point(goal, height), item.id),
        carry,
        scene_obstacles(scene, item, there),
    )
    return pick, place
