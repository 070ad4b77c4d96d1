"""The block family's fixtures as obstacles: the walls of every box.

Boxes are not scene objects: a cover goal marks where a box's lid sits, so the box is four
walls under it, of the footprint of the covers seen in the scene (``WALL`` thick, from the
table up to the lid's underside).
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneObject
from manigraph_skills.obstacles import Obstacle

#: Assumed box wall thickness, metres (the physics world's boxes: 1 cm).
WALL = 0.01


def box_walls(
    scene: Scene, moving: SceneObject | None = None, at: np.ndarray | None = None
) -> list[Obstacle]:
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
