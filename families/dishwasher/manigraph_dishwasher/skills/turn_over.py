"""Which way to turn a dish over: the geometry of the regrasp manoeuvre, no motion.

A top-down grasp turns a dish about the vertical only. To give it another up axis the Panda
drivers *tilt* it: take it top-down with the fingers closing along one of its horizontal
axes, turn the hand a quarter about that (horizontal) closing axis, so the fingers point
sideways along the counter, set the dish down on the counter and let go. The dish has then
turned a quarter about a horizontal axis; the ordinary top-down grasp finishes the turn about
the vertical as it takes the dish to its goal. One tilt changes the up axis to either
horizontal axis (±), two reach the opposite one: so any of the six orientations is reachable
in at most two tilts, provided the fingers span the dish across the axis it turns about
(``MAX_GRIP_WIDTH``).

Rotations are 3x3 matrices, world from object (columns: the object's axes in the world).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.messages import Quaternion
from manigraph_shared.panda import FINGER_OPEN
from manigraph_skills.grasp_choice import HORIZONTAL

#: Widest a dish may be across the fingers for a tilt, metres: the open fingers' 8 cm less
#: room to come down beside it.
MAX_GRIP_WIDTH = 2 * FINGER_OPEN - 0.01


def quaternion_of(rotation: np.ndarray) -> Quaternion:
    """The unit quaternion of a rotation matrix (Shepperd's method)."""
    m = rotation
    trace = float(np.trace(m))
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        w, x, y, z = (
            0.25 * s,
            (m[2, 1] - m[1, 2]) / s,
            (m[0, 2] - m[2, 0]) / s,
            (m[1, 0] - m[0, 1]) / s,
        )
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        v = np.zeros(3)
        v[i] = 0.25 * s
        v[j] = (m[j, i] + m[i, j]) / s
        v[k] = (m[k, i] + m[i, k]) / s
        w = (m[k, j] - m[j, k]) / s
        x, y, z = v
    return Quaternion(x=float(x), y=float(y), z=float(z), w=float(w))


def up_index(rotation: np.ndarray) -> int:
    """The discrete orientation (``manigraph_shared.orientations``) whose up axis is the
    object axis nearest world +z."""
    up = rotation[2]
    axis = int(np.argmax(np.abs(up)))
    return {2: 0, 1: 2, 0: 4}[axis] + (0 if up[axis] > 0 else 1)


def top_down_rotation(yaw: float) -> np.ndarray:
    """The hand pointing down at ``yaw`` (``motion.model.top_down``): fingers close along its
    y axis, ``(sin yaw, -cos yaw, 0)``."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def sideways_hands() -> list[np.ndarray]:
    """The hand rotations a dish is set down with: fingers pointing horizontally, closing
    along a horizontal axis. Closing along the base x axis (pointing along the counter,
    either way) first, then closing along y (pointing away from the robot)."""
    x, y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    # (Pointing back at the robot, the wrist folds over the dish: no such hand.)
    pairs = [(x, y), (-x, y), (x, -y), (-x, -y), (y, x), (-y, x)]
    return [np.column_stack([np.cross(close, point), close, point]) for close, point in pairs]


@dataclass(frozen=True)
class Tilt:
    """Take the dish top-down at ``pick_yaw`` (fingers along the axis it turns about)."""

    pick_yaw: float
    up_after: int


def tilts(dish: np.ndarray, size: np.ndarray) -> list[Tilt]:
    """Every single tilt of a dish at rotation ``dish`` with extents ``size``: for each
    horizontal axis the fingers span, the up axes a sideways set-down can leave it with."""
    found = []
    for axis in range(3):
        direction = dish[:, axis]
        if abs(direction[2]) > HORIZONTAL or size[axis] > MAX_GRIP_WIDTH:
            continue
        yaw = float(np.arctan2(direction[0], -direction[1]))
        held = top_down_rotation(yaw).T @ dish
        ups = {up_index(hand @ held) for hand in sideways_hands()}
        found += [Tilt(yaw, up) for up in sorted(ups)]
    return found


def next_tilts(dish: np.ndarray, size: np.ndarray, targets: tuple[int, ...]) -> list[Tilt]:
    """The tilts that bring the dish to an up axis in ``targets`` (the orientations it may
    end in: ``orientations.postures_like``), or (if none does) those after which one does;
    empty if the dish cannot be turned there (too wide across every axis it would turn
    about)."""
    direct = [t for t in tilts(dish, size) if t.up_after in targets]
    if direct:
        return direct
    steps = []
    for tilt in tilts(dish, size):
        held = top_down_rotation(tilt.pick_yaw).T @ dish
        for hand in sideways_hands():
            after = hand @ held
            if up_index(after) == tilt.up_after and any(
                t.up_after in targets for t in tilts(after, size)
            ):
                steps.append(tilt)
                break
    return steps


def set_down_hands(hand: np.ndarray, dish: np.ndarray, wanted: list[int]) -> list[np.ndarray]:
    """The sideways hand rotations that leave a dish, held at ``dish`` by a hand at rotation
    ``hand``, with an up axis in ``wanted`` (the earlier ones in it first). The hand gets
    there by turning about the vertical (top-down still), then a quarter about its closing
    axis."""
    held = hand.T @ dish
    sides = sideways_hands()
    return [side for up in wanted for side in sides if up_index(side @ held) == up]
