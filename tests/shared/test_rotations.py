"""The one quaternion -> rotation matrix every service uses."""

from __future__ import annotations

import math

import numpy as np

from manigraph_shared.messages import Quaternion
from manigraph_shared.orientations import ORIENTATIONS
from manigraph_shared.rotations import rotation_matrix


def test_a_quarter_turn_about_z_takes_x_to_y() -> None:
    h = math.sqrt(0.5)
    turn = rotation_matrix(Quaternion(x=0.0, y=0.0, z=h, w=h))
    assert np.allclose(turn @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    assert np.allclose(rotation_matrix((0.0, 0.0, 0.0, 1.0)), np.eye(3))


def test_every_discrete_orientation_is_a_proper_rotation_with_its_named_axis_up() -> None:
    up_axes = [(2, 1), (2, -1), (1, 1), (1, -1), (0, 1), (0, -1)]  # orientations.py's table
    for q, (axis, sign) in zip(ORIENTATIONS, up_axes, strict=True):
        rotation = rotation_matrix(q)
        assert np.allclose(rotation @ rotation.T, np.eye(3)) and np.isclose(
            np.linalg.det(rotation), 1.0
        )
        assert np.isclose(rotation[2, axis], sign)  # that object axis points along world +z
        assert np.allclose(rotation_matrix((q.x, q.y, q.z, q.w)), rotation)
