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
* **How high to take a dish**: at its centre, unless the hand (its underside
  ``HAND_ABOVE_TCP`` over the TCP, 20 cm long) would come down onto a taller dish beside it
  (a plate on its rim, 6.4 cm, next to a bowl, 3.5 cm): then higher, as far as leaves
  ``GRIP_DEPTH`` of the dish between the fingertips (``dish_grasp_height``).
* **How wide to open**: around a dish the fingers open to its width across them plus
  ``OPENING_MARGIN`` (a plate on its rim: 3.5 cm), not fully (8 cm): on the counter's rows
  8 cm apart and in slots 5.5 cm apart, fully open fingers reach into the neighbouring dish.
  Within ``FULLY_OPEN_WITHIN`` of fully open (a bowl), and for covers, fully. A block is
  taken fully open (room for a pose a centimetre or two off) and let go of the dish way
  (``release_opening``): fully open, the far finger's pad reaches 4.6 cm beyond a 4 cm
  block's side, into a bin's wall 2 cm from the goal (colour sort); it jammed there, and
  the hand rising dragged the block 1.7 cm off its goal, towards the wall.
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
from manigraph_shared.rotations import rotation_matrix
from manigraph_skills.drivers.base import Grasp
from manigraph_skills.obstacles import scene_obstacles

#: Added to the fingers' reach before an axis counts as free, metres.
MARGIN = 0.005
#: A horizontal axis has at most this vertical component.
HORIZONTAL = 0.5
#: Between a carried object's underside and what it passes over, metres.
CARRY_CLEARANCE = 0.02
#: Hand yaw that turns the closing axis from x to y.
TURN_TO_Y = -np.pi / 2
#: The hand's underside above the TCP along its length (its collision mesh), metres, and
#: how far from the TCP along the closing axis it reaches.
HAND_ABOVE_TCP = 0.037
HAND_HALF_LENGTH = 0.104
#: Room kept between the hand's underside and a dish beside the one it takes, metres.
HAND_CLEARANCE = 0.004
#: Least height of a dish between the fingertips when it is taken above its centre, metres.
GRIP_DEPTH = 0.015
#: The open fingers' gap beyond a dish's width across them, metres (half on each side).
OPENING_MARGIN = 0.02
#: An opening this close to fully open is fully open, metres: a bowl (5 cm) let go of with
#: the fingers 7 cm apart stayed on one of them in the sim (its fingers hold only by their
#: drives short of the joint limit); the half centimetre a side it would spare is not worth it.
#: (Taken with the fingers 7 cm apart and let go of fully open, it stayed on them too, every
#: time: it left with the hand.)
FULLY_OPEN_WITHIN = 0.015
DISHES = ("plate", "bowl")


def dish_opening(item: SceneObject, closing: np.ndarray | None = None) -> float | None:
    """How far apart to open the fingers around ``item``: its width along the closing axis
    ``closing`` (a horizontal direction; None: whichever of its two horizontal axes is wider)
    plus ``OPENING_MARGIN``; fully open (8 cm) within ``FULLY_OPEN_WITHIN`` of it; None
    (fully open, as before) for a block or a cover."""
    if item.category.value not in DISHES:
        return None
    rotation = rotation_matrix(item.orientation)
    size = np.array(item.size.as_tuple())
    if closing is None:
        horizontal = np.argsort(np.abs(rotation[2]))[:2]  # the two axes nearest level
        width = float(size[horizontal].max())
    else:
        width = float(size[int(np.argmax(np.abs(rotation.T @ closing)))])
    opening = width + OPENING_MARGIN
    return opening if opening <= 2 * FINGER_OPEN - FULLY_OPEN_WITHIN else 2 * FINGER_OPEN


def release_opening(item: SceneObject) -> float | None:
    """How far apart to open the fingers letting go of ``item`` at its goal: a block as a
    dish (its wider horizontal side plus ``OPENING_MARGIN``: what stands beside the goal and
    the skills do not see, a bin's wall, is not reached); a dish as it was taken; a cover
    fully (None)."""
    if item.category is not ObjectCategory.BLOCK:
        return dish_opening(item)
    rotation = rotation_matrix(item.orientation)
    size = np.array(item.size.as_tuple())
    width = float(size[np.argsort(np.abs(rotation[2]))[:2]].max())
    opening = width + OPENING_MARGIN
    return opening if opening <= 2 * FINGER_OPEN - FULLY_OPEN_WITHIN else 2 * FINGER_OPEN


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


def vertical_half(item: SceneObject) -> float:
    """Half the height of ``item`` as it lies (its box turned by its orientation)."""
    size = np.array(item.size.as_tuple())
    return float(np.abs(rotation_matrix(item.orientation)[2]) @ size) / 2


def dish_grasp_height(scene: Scene, item: SceneObject, at: np.ndarray, height: float) -> float:
    """TCP above the centre of dish ``item`` (lying at ``at``) to take it with: ``height``,
    or higher if the hand would come down onto a taller dish within its length, as far as
    leaves ``GRIP_DEPTH`` of the dish between the fingertips."""
    if item.category.value not in DISHES:
        return height
    tallest = 0.0
    for other in scene.objects:
        if other.id == item.id or not other.visible:
            continue
        reach = HAND_HALF_LENGTH + float(max(other.size.as_tuple())) / 2
        if np.linalg.norm(np.array(other.position.as_tuple()[:2]) - at[:2]) < reach:
            tallest = max(tallest, other.position.z + vertical_half(other))
    needed = tallest + HAND_CLEARANCE - HAND_ABOVE_TCP - at[2]
    highest = vertical_half(item) - GRIP_DEPTH + FINGER_BELOW_TCP
    return max(height, min(float(needed), highest))


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
    thin = rotation_matrix(item.orientation)[:, 2]
    if abs(thin[2]) > HORIZONTAL:
        return None
    return TURN_TO_Y if abs(thin[1]) > abs(thin[0]) else 0.0


def choose_grasps(scene: Scene, item: SceneObject, goal: Vector3) -> tuple[Grasp, Grasp]:
    """The grasp to pick ``item`` with, and the one to set it down at ``goal`` with, each
    with the obstacles the arm must avoid on the way (``obstacles``)."""
    here, there = np.array(item.position.as_tuple()), np.array(goal.as_tuple())
    height = grasp_height(item.category.value, np.array(item.size.as_tuple()))
    height = dish_grasp_height(scene, item, here, height)
    carry = carry_height(scene, item, height)
    turn = plate_turn(item)
    if turn is not None:
        # Into its slot across y whichever way it was taken: the slot's ribs hold it so.
        thin = rotation_matrix(item.orientation)[:, 2]
        opening = dish_opening(item, thin)
        return (
            Grasp(height, turn, carry, scene_obstacles(scene, item, here), np.pi, opening),
            Grasp(height, TURN_TO_Y, carry, scene_obstacles(scene, item, there), np.pi, opening),
        )
    opening = dish_opening(item)
    pick = Grasp(
        height,
        closing_turn(scene, _point(item.position, height), item.id),
        carry,
        scene_obstacles(scene, item, here),
        opening=opening,
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
        opening=release_opening(item),
    )
    return pick, place
