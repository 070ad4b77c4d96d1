"""The ArUco pipeline's service and a stale camera (``stale_camera.py``): rendered frames."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from stale_camera import check_stale_camera

from manigraph_shared.messages import CompressedImage, Message, TaskLayout

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[2]
FRAMES = Path(__file__).parent / "frames"
CALIBRATION = str(ROOT / "examples" / "calibration" / "sim-front.yaml")


def _image(data: bytes, sequence: int, stamp: float) -> list[Message]:
    return [
        CompressedImage(camera="front", stamp=stamp, sequence=sequence, format="png", data=data)
    ]


def test_a_stale_or_frozen_marker_camera_never_passes_for_a_fresh_one(tmp_path: Path) -> None:
    record = json.loads((FRAMES / "stack4-start.json").read_text())
    layout = TaskLayout.from_builtins({**record["layout"], "stamp": time.time() - 1.0})
    png = (FRAMES / "stack4-start.png").read_bytes()
    check_stale_camera(
        tmp_path,
        ["--markers", "sim", "--calibration", CALIBRATION, "--stale-after", "2"],
        layout,
        good=lambda sequence, stamp: _image(png, sequence, stamp),
        bad=lambda sequence, stamp: _image(b"junk", sequence, stamp),
        bad_words="image does not decode",
    )
