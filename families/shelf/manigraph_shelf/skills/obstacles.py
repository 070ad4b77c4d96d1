"""The shelf family's fixtures as obstacles: the cupboard's boards and walls
(:mod:`manigraph_shelf.cupboard`), where a shelf scene's slots say the cupboard stands."""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import Scene, SceneObject
from manigraph_shelf.cupboard import board_name, cupboard_panels
from manigraph_shelf.shelf_geometry import (
    OBJECT_SIZE,
    ROW_ATTRIBUTE,
    ShelfGeometry,
    geometry_for,
    is_shelf_scene,
)
from manigraph_skills.obstacles import SUPPORT_GAP, Obstacle


def scene_geometry(scene: Scene) -> ShelfGeometry:
    """The cupboard of a shelf scene: the one its number of slots is built for."""
    return geometry_for(sum(ROW_ATTRIBUTE in goal.attributes for goal in scene.goals))


def cupboard_obstacles(
    scene: Scene, moving: SceneObject | None = None, at: np.ndarray | None = None
) -> list[Obstacle]:
    """Every board and wall of a shelf scene's cupboard (none for another scene). The board a
    block is set down on at ``at`` (a slot above the bottom level) is a support: the fingers
    may come close to it."""
    if not is_shelf_scene(scene):
        return []
    geometry = scene_geometry(scene)
    under = None
    if moving is not None and at is not None:
        for level, top in enumerate(geometry.board_tops):
            if level > 0 and abs(at[2] - OBJECT_SIZE / 2 - top) <= SUPPORT_GAP:
                under = board_name(level)
    return [
        Obstacle(panel.name, panel.centre, panel.size, support=panel.name == under)
        for panel in cupboard_panels(geometry)
    ]
