"""What the arm must not touch, read off the scene: blocks, covers, towers and box walls.

Every visible object is a box of its size at its pose, except the one being moved (it is
between the fingers). Objects that *support* the grasp or the goal (directly under the moved
object, or under the goal it is set down on) are marked: the hand and fingers may come close
to them, the arm links may not. A task family's fixtures that are not scene objects
(a box's walls under its lid goal, a rack's floor and handle) are the family's own
obstacles (``SkillFamily.obstacles``). The table is the collision model's own
(``motion.collision``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.messages import Scene, SceneObject
from manigraph_skills.family import families

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
    for family in families():  # each family's fixtures: box walls, rack floors and handles
        fixtures = family.part("obstacles")
        if fixtures is not None:
            found.extend(fixtures(scene, moving, at))
    return tuple(found)
