"""The RGB-D pipeline's service and a stale camera (``stale_camera.py``): drawn frames."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from stale_camera import check_stale_camera
from synthetic import draw

from manigraph_perception.calibration_file import load_calibration
from manigraph_shared.messages import (
    CompressedImage,
    DepthImage,
    GoalCategory,
    LayoutGoal,
    LayoutObject,
    Message,
    ObjectCategory,
    TaskLayout,
    Vector3,
)
from manigraph_sim.physics.depth_noise import encode_depth_png

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[3]
CALIBRATION = str(ROOT / "examples" / "calibration" / "sim-front.yaml")
RED = (0.5, 0.0, 0.02)


def _frame(png: bytes, depth: np.ndarray, sequence: int, stamp: float) -> list[Message]:
    return [
        DepthImage(camera="front", stamp=stamp, sequence=sequence, data=encode_depth_png(depth)),
        CompressedImage(camera="front", stamp=stamp, sequence=sequence, format="png", data=png),
    ]


def test_a_stale_or_frozen_depth_camera_never_passes_for_a_fresh_one(tmp_path: Path) -> None:
    bgr, depth = draw(load_calibration(CALIBRATION), [(RED, 0.04, "red")])
    png = cv2.imencode(".png", bgr)[1].tobytes()
    place = Vector3(x=RED[0], y=RED[1], z=RED[2])
    size = Vector3(x=0.04, y=0.04, z=0.04)
    layout = TaskLayout(
        episode_id="stale",
        stamp=time.time() - 1.0,
        objects=[
            LayoutObject(id="block_0", category=ObjectCategory.BLOCK, position=place, size=size)
        ],
        goals=[LayoutGoal(id="goal_0", category=GoalCategory.BLOCK, position=place)],
    )
    check_stale_camera(
        tmp_path,
        ["--pipeline", "rgbd", "--calibration", CALIBRATION, "--stale-after", "2"],
        layout,
        good=lambda sequence, stamp: _frame(png, depth, sequence, stamp),
        bad=lambda sequence, stamp: _frame(png, depth[::2, ::2], sequence, stamp),
        bad_words="depth 320 x 240",
    )
