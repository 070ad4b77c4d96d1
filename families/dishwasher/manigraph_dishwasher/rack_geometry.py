"""The dishwasher's racks as built and grasped (docs/dishwasher.md), written once for its sim
(which builds each rack's floor and handle tab), its skills (which keep the arm off them and
tell the driver where the tab is, ``skills.trays``) and its tests. A common module of the
package: it imports no service.
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import ConfigError

#: The racks (``Scene.fixtures`` of kind ``rack``): where the gripper takes each rack's handle,
#: relative to the position a ``Scene`` reports for the rack (x, y, z, metres). The physical handle
#: is a tab, 1.5 cm across y, sticking out of the rack's front towards the robot, beside the rack
#: (the top rack's at its right side, the bottom rack's at its left), joined to the floor's front
#: corner by a bar; the fingers close across it (along y). Beside the racks, a handle is beyond the
#: counter's dishes and the slots: a hand over either never meets it (in the middle, a pulled-out
#: top rack's tab was over the counter's far row at the wrist's height, and a dish lying under it
#: could not be taken). Each sticks out 8 cm in front of the reported handle, so the hand takes the
#: bottom one in front of the top rack standing above it. Here so the sim builds the tab where the
#: skills grasp it.
RACK_GRIP_OFFSET: dict[str, tuple[float, float, float]] = {
    "rack_top": (-0.08, 0.44, 0.015),
    "rack_bottom": (-0.08, -0.44, 0.015),
}
#: How far a rack slides out towards the robot (-x) when pulled, metres.
RACK_TRAVEL = 0.16
#: The tab's thickness across y, metres (what the closed fingers hold).
RACK_TAB_THICKNESS = 0.015


def rack_grip(rack_id: str) -> np.ndarray:
    """The offset of rack ``rack_id``'s grip from its reported position; ``ConfigError``
    naming the rack if it has no handle."""
    try:
        return np.array(RACK_GRIP_OFFSET[rack_id])
    except KeyError:
        raise ConfigError("rack_id", f"'{rack_id}' has no handle to grasp") from None


#: A rack's floor, relative to the rack's centre (the reported handle is ``RACK_HANDLE_X``
#: from it along x), metres: x from its front (robot side) to its back, half width along y,
#: top surface height, thickness. Here so the skills can keep the arm off a pulled-out
#: rack's floor (it reaches over the counter's far row).
RACK_HANDLE_X = -0.09
RACK_FLOOR_X = (-0.08, 0.075)
RACK_FLOOR_HALF_Y = 0.34
RACK_FLOOR_TOP = 0.005
RACK_FLOOR_THICKNESS = 0.01
#: A rack's handle tab's height relative to the rack's centre (bottom, top), metres.
RACK_TAB_Z = (0.0, 0.03)


def rack_handle_boxes(rack_id: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rack ``rack_id``'s handle as boxes (low and high corners relative to the rack's
    centre, metres): its tab, from behind the grip to just short of the floor's front (clear
    of the cabinet's walls when pushed in), and for a tab beside the floor the bar joining
    it to the floor's corner. Here so the sim builds the handle where the skills keep the
    arm off it (a hand coming down beside a pulled-out top rack met its tab and pushed the
    rack back in)."""
    grip_x, grip_y, _ = rack_grip(rack_id)
    grip_x += RACK_HANDLE_X
    half = RACK_TAB_THICKNESS / 2
    front = RACK_FLOOR_X[0] - 0.005
    low, high = RACK_TAB_Z
    boxes = [
        (np.array([grip_x - 0.03, grip_y - half, low]), np.array([front, grip_y + half, high]))
    ]
    if abs(grip_y) + half > RACK_FLOOR_HALF_Y:
        side = float(np.sign(grip_y))
        inner, outer = side * RACK_FLOOR_HALF_Y, grip_y + side * half
        boxes.append(
            (
                np.array([front - 0.01, min(inner, outer), low]),
                np.array([front, max(inner, outer), high]),
            )
        )
    return boxes
