"""Rendered frames (``frames/``, made by ``make_frames.py``) and the sim camera's calibration."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from manigraph_perception.calibration_file import Calibration, load_calibration
from manigraph_shared.markers import MarkerMap, sim_marker_map
from manigraph_shared.messages import TaskLayout

ROOT = Path(__file__).resolve().parents[2]
FRAMES = Path(__file__).parent / "frames"
SIM_CALIBRATION = ROOT / "examples" / "calibration" / "sim-front.yaml"


class Frame:
    def __init__(self, name: str) -> None:
        self.grey = cv2.imread(str(FRAMES / f"{name}.png"), cv2.IMREAD_GRAYSCALE)
        self.png = (FRAMES / f"{name}.png").read_bytes()
        record = json.loads((FRAMES / f"{name}.json").read_text())
        self.layout = TaskLayout.from_builtins(record["layout"])
        self.truth = {body: np.array(pose[0]) for body, pose in record["truth"].items()}


@pytest.fixture(scope="session")
def calibration() -> Calibration:
    return load_calibration(SIM_CALIBRATION)


@pytest.fixture(scope="session")
def markers() -> MarkerMap:
    return sim_marker_map()


@pytest.fixture(scope="session")
def frame() -> type[Frame]:
    return Frame
