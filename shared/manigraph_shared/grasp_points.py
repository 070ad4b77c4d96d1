"""Where a gripper takes hold of each category of object, shared by the sim and the skills.

A block is grasped at its centre. A cover is a plate wider than any gripper opens, so the
physical cover carries a handle, a small cube fixed at the centre of its top face (the same
rigid body); the gripper takes the handle. A ``Scene`` still reports a cover's plate: its
centre and size, as the geometric world and the planner know it. A family's fixtures (a rack's
handle) are grasped where its own package says.
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import ConfigError

#: Full extents of a cover's handle, metres: narrower than the open fingers (8 cm) and tall
#: enough that the fingertips stay clear of the plate when the TCP is at its centre.
COVER_HANDLE_SIZE = np.array([0.03, 0.03, 0.03])


def handle_offset(cover_size: np.ndarray) -> float:
    """Height of a cover handle's centre above the cover's centre."""
    return float(cover_size[2] / 2 + COVER_HANDLE_SIZE[2] / 2)


def grasp_height(category: str, size: np.ndarray) -> float:
    """How far above an object's centre the TCP is put to grasp it, metres."""
    if category in ("block", "plate", "bowl"):  # dishes: at the centre, as a block
        return 0.0
    if category == "cover":
        return handle_offset(size)
    raise ConfigError("category", f"'{category}' is not 'block', 'cover', 'plate' or 'bowl'")
