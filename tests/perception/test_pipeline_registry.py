"""The perception pipelines are registered units: ``--pipeline`` looks them up."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.pipeline import CameraSetup
from manigraph_perception.registry import PIPELINES, open_pipeline
from manigraph_perception.world_belief import WorldConfig
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_testkit.testing import Stack, free_port

ROOT = Path(__file__).resolve().parents[2]
CALIBRATION = str(ROOT / "examples" / "calibration" / "sim-front.yaml")


def test_the_registry_names_every_pipeline_and_imports_none_until_one_is_opened() -> None:
    code = (
        "import sys; from manigraph_perception.registry import PIPELINES; "
        "print(PIPELINES.names(), sorted(m for m in sys.modules "
        "if m == 'cv2' or m.startswith('manigraph_perception.pipelines')))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "['aruco', 'rgbd'] []", result.stderr
    assert set(PIPELINES["rgbd"].parts) == {"image", "depth"}  # opened: imported now


def test_an_option_of_another_pipeline_is_refused_by_name(calibration: Calibration) -> None:
    setup = CameraSetup("bus", "front", calibration, WorldConfig())
    with pytest.raises(ConfigError, match=r"pipeline.markers: not an option of pipeline 'rgbd'"):
        open_pipeline("rgbd", setup, markers="sim")
    with pytest.raises(ConfigError, match=r"markers: --pipeline aruco needs a marker map"):
        open_pipeline("aruco", setup)


@pytest.mark.integration
def test_an_unknown_pipeline_is_one_line_naming_the_known_ones(tmp_path: Path) -> None:
    running = Stack(free_port(), tmp_path)
    args = ["--pipeline", "lidar", "--camera", "bus", "--calibration", CALIBRATION]
    result = running.run("perception", *args, timeout=60)
    assert result.returncode == CONFIG_EXIT_CODE, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines[-1] == "manigraph perception: pipeline: 'lidar' is not one of: aruco, rgbd"
