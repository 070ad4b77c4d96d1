"""Where in its slot to set a bowl down so that it cannot land on a neighbour.

Bowl slots are 5.5 cm apart for 5 cm bowls: 2.5 mm to spare on either side of a bowl square
to its row. A bowl turned about the vertical needs more: one let go of sideways by a
turn-over comes to rest turned (12 degrees, seed 15012), is taken and set into its slot so,
and reaches 3 mm past its half of the row (a 5 cm square turned by t spans
5 (cos t + sin t) cm). The next bowl set down beside it met its corner on the way down and
knocked it 23 mm off its slot, where it blocked both its slots (issue 33).

So a bowl is set down where the dishes beside its slot, as the scene sees them (position and
turn), leave it ``CLEARANCE`` on either side: its slot's centre if they do, else moved along
the row as little as that takes, by at most ``MAX_SHIFT`` (it still stands in its slot, within
10 mm of it); between neighbours that leave too little room either way, in the middle.
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_shared.rotations import rotation_matrix

#: Room kept between a bowl set down and the dish beside it, metres.
CLEARANCE = 0.0015
#: Farthest a bowl is set down from its slot's centre along the row, metres.
MAX_SHIFT = 0.008
#: A dish is beside the slot when its centre is this close along the row (a slot and a half),
#: metres, at the slot's height within ``SAME_LEVEL``.
BESIDE = 0.09
SAME_LEVEL = 0.03


def half_across(item: SceneObject, axis: int) -> float:
    """Half the extent of ``item`` along world ``axis`` as it lies (its box turned by its
    orientation, its turn about the vertical included)."""
    size = np.array(item.size.as_tuple())
    return float(np.abs(rotation_matrix(item.orientation)[axis]) @ size) / 2


def set_down_point(scene: Scene, item: SceneObject, goal: SceneGoal) -> Vector3:
    """Where to set bowl ``item`` down in slot ``goal`` (the rows run along y): the slot's
    position, moved along the row if a neighbour leaves too little room there."""
    if item.category.value != "bowl":
        return goal.position
    x, y, z = goal.position.as_tuple()
    half = max(item.size.x, item.size.y) / 2  # set down square to the row
    left, right = -np.inf, np.inf  # the neighbours' nearest edges
    for other in scene.objects:
        if other.id == item.id or not other.visible:
            continue
        ox, oy, oz = other.position.as_tuple()
        if abs(oz - z) > SAME_LEVEL or abs(oy - y) > BESIDE:
            continue
        if abs(ox - x) >= half + half_across(other, 0):
            continue  # not in the row
        reach = half_across(other, 1)
        if oy < y:
            left = max(left, oy + reach)
        else:
            right = min(right, oy - reach)
    low, high = left + CLEARANCE + half, right - CLEARANCE - half
    where = float(np.clip(y, low, high)) if low <= high else (low + high) / 2
    where = float(np.clip(where, y - MAX_SHIFT, y + MAX_SHIFT))
    return Vector3(x=x, y=where, z=z)
