"""Rotation matrices of quaternions, written once for every service (the sim's dish yaw, the
skills' turn-over, perception's world belief, the demonstration page's extents)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from manigraph_shared.messages.base import Quaternion


def rotation_matrix(q: Quaternion | Sequence[float] | np.ndarray) -> np.ndarray:
    """The 3 x 3 rotation matrix of the unit quaternion ``q``: a :class:`Quaternion`, or its
    (x, y, z, w) components. Not normalised here: pass a unit quaternion."""
    x, y, z, w = (q.x, q.y, q.z, q.w) if isinstance(q, Quaternion) else (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
