"""The six discrete orientations a placed object may be asked to take (the paper's, from its
dish-loading task).

An action's ``orientation_index`` names one of them; a placed object takes it. Declared once
here so the sim, the skills and the planner read an index the same way, whatever the family.
Index ``i`` says which of the object's axes points up (world +z):

====  ==================  ======================================================
 i    object axis up      e.g.
====  ==================  ======================================================
 0    +z                  lying as modelled: a plate flat, a bowl opening up
 1    -z                  upside down (flipped about x): a bowl in its rack slot
 2    +y                  on its rim (+90 deg about x): a plate standing in its slot
 3    -y                  on its rim, the other way (-90 deg about x)
 4    +x                  on its side (-90 deg about y)
 5    -x                  on its side, the other way (+90 deg about y)
====  ==================  ======================================================
"""

from __future__ import annotations

import math
from typing import Final

from manigraph_shared.messages.base import Quaternion

_H = math.sqrt(0.5)

#: Index -> quaternion (x, y, z, w) that takes the object's frame to the world's.
ORIENTATIONS: Final[tuple[Quaternion, ...]] = (
    Quaternion(),
    Quaternion(x=1.0, w=0.0),
    Quaternion(x=_H, w=_H),
    Quaternion(x=-_H, w=_H),
    Quaternion(y=-_H, w=_H),
    Quaternion(y=_H, w=_H),
)
NUM_ORIENTATIONS: Final = len(ORIENTATIONS)
#: Names for logs and docs.
ORIENTATION_NAMES: Final = (
    "up",
    "upside-down",
    "rim-y",
    "rim-y-flipped",
    "side-x",
    "side-x-flipped",
)
#: Two postures by name: standing on its rim (a plate in its rack slot) and upside down (a
#: bowl in its slot).
UPRIGHT: Final = 2
UPSIDE_DOWN: Final = 1
#: The orientations of a plate standing on its rim (its thin axis level): "rim-y" and its
#: flip, "side-x" and its flip. A plate is square (as a round plate, which it stands for, is
#: symmetric) about its thin axis, so these are one posture, whichever edge is down; the
#: fingers pinch it across its faces and it may pivot about them on the way.
PLATE_ON_RIM: Final = (2, 3, 4, 5)


def postures_like(category: str, index: int) -> tuple[int, ...]:
    """The orientations in which a dish of ``category`` stands as in orientation ``index``:
    a plate on its rim whichever edge is down (``PLATE_ON_RIM``), ``index`` first; else
    ``index`` alone."""
    if category == "plate" and index in PLATE_ON_RIM:
        return (index, *(other for other in PLATE_ON_RIM if other != index))
    return (index,)


def orientation(index: int) -> Quaternion:
    """The quaternion of orientation ``index``; ``ValueError`` naming the field if unknown."""
    if not 0 <= index < NUM_ORIENTATIONS:
        raise ValueError(f"orientation_index: must be in 0..{NUM_ORIENTATIONS - 1}, got {index}")
    return ORIENTATIONS[index]


def nearest_orientation(q: Quaternion) -> int:
    """The index of the discrete orientation closest to ``q`` (largest |dot product|)."""
    dots = [abs(q.x * o.x + q.y * o.y + q.z * o.z + q.w * o.w) for o in ORIENTATIONS]
    return max(range(NUM_ORIENTATIONS), key=lambda i: (dots[i], -i))


def up_axis_orientation(q: Quaternion) -> int:
    """The index of the discrete orientation whose up axis is the object axis nearest to
    world +z in pose ``q``, whatever the object's turn about the vertical (a physical dish
    set down by a top-down grasp keeps its index at any yaw; ``nearest_orientation`` would
    not)."""
    x, y, z, w = q.x, q.y, q.z, q.w
    # World +z in the object's frame: the third row of the rotation matrix.
    up = (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    axis = max(range(3), key=lambda i: abs(up[i]))
    positive = up[axis] > 0
    return {2: 0, 1: 2, 0: 4}[axis] + (0 if positive else 1)
