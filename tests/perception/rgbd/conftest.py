"""RGB-D frames rendered by the physics sim (once per test session), with the truth."""

from __future__ import annotations

import pytest
from rgbd_frames import RenderedFrame, render_frames

from manigraph_perception.calibration_file import Calibration


@pytest.fixture(scope="session")
def rendered() -> dict[str, RenderedFrame]:
    return {frame.name: frame for frame in render_frames()}


@pytest.fixture(scope="session")
def calibration() -> Calibration:
    from manigraph_sim.physics.camera import CameraConfig, ideal_calibration

    k, base_T_camera = ideal_calibration(CameraConfig())
    return Calibration(k, base_T_camera=base_T_camera)
