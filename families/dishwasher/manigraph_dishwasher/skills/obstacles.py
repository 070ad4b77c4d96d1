"""The dishwasher family's fixtures as obstacles: every rack's floor and handle."""

from __future__ import annotations

import numpy as np

from manigraph_dishwasher.fixtures import racks
from manigraph_dishwasher.rack_geometry import (
    RACK_FLOOR_HALF_Y,
    RACK_FLOOR_THICKNESS,
    RACK_FLOOR_TOP,
    RACK_FLOOR_X,
    RACK_HANDLE_X,
    rack_handle_boxes,
)
from manigraph_shared.messages import Scene, SceneObject
from manigraph_skills.obstacles import SUPPORT_GAP, Obstacle


def rack_obstacles(
    scene: Scene, moving: SceneObject | None = None, at: np.ndarray | None = None
) -> list[Obstacle]:
    """The floor and the handle (``rack_geometry.rack_handle_boxes``) of every dishwasher
    rack, where it is. The floor: pulled out, it reaches over the
    counter's far row, where a hand lifting a dish would meet it; pushed in, the top rack's
    front edge is over the pulled-out bottom rack's far slots, where the wrist reaching into
    them met it (and stopped 5 cm short: the bowl it held fell off the rack). The slots' ribs
    and the dishes in them are not floors. A floor under ``at``, where ``moving`` is set down
    (a slot of that rack: within the floor's footprint, no higher above it than the dish's
    largest half extent, whichever way up it stands), is a support, like a block under a
    goal: the fingers may come close to it."""
    found = []
    for rack in racks(scene):
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
