"""Which starts the tripod camera can see: a body partly out of its picture cannot be found by
perception that finds objects by sight, and the sim names it at the reset."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_sim.physics.camera import CameraConfig, ideal_calibration, out_of_view, top_corners

BLOCK = np.array([0.04, 0.04, 0.04])


def unseen(config: CameraConfig, corners: np.ndarray) -> bool:
    k, base_T_camera = ideal_calibration(config)
    return out_of_view(k, base_T_camera, (config.width, config.height), corners)


@pytest.mark.parametrize(
    ("x", "y", "seen"),
    [
        (0.30, 0.10, True),  # the middle of the workspace
        (0.39, 0.33, True),
        (0.47, -0.33, True),
        (0.474, 0.546, False),  # colour place, seed 49103: off the right edge of the image
        (0.474, -0.546, False),
        (1.20, 0.0, False),  # behind the tripod
    ],
)
def test_a_start_is_seen_only_when_its_whole_top_is_in_the_picture(
    x: float, y: float, seen: bool
) -> None:
    corners = top_corners(np.array([x, y, 0.02]), BLOCK)
    assert unseen(CameraConfig(), corners) is (not seen)


def test_a_wider_lens_sees_what_the_default_does_not() -> None:
    corners = top_corners(np.array([0.474, 0.546, 0.02]), BLOCK)
    assert unseen(CameraConfig(), corners)
    assert not unseen(CameraConfig(fovy_degrees=75.0), corners)
