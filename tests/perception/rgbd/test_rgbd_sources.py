"""RGB-D sources behind one interface: a recording replayed from MCAP (a real file written
by the recorder's writer), a RealSense refused clearly without its package."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from synthetic import draw

from manigraph_perception.calibration_file import load_calibration
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_perception.pipelines.rgbd.sources import (
    McapRgbdSource,
    RealSenseSource,
    open_rgbd_source,
)
from manigraph_shared.errors import ConfigError
from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import CameraInfo, CompressedImage, DepthImage
from manigraph_sim.physics.depth_noise import encode_depth_png

ROOT = Path(__file__).resolve().parents[3]
CALIBRATION = load_calibration(ROOT / "examples" / "calibration" / "sim-front.yaml")


def _record(path: Path, places: list[tuple[float, float, float]]) -> None:
    writer = McapLogWriter(path)
    for sequence, place in enumerate(places):
        bgr, depth = draw(CALIBRATION, [(place, 0.04, "blue")])
        stamp = time.time()
        ok, png = cv2.imencode(".png", bgr)
        assert ok
        depth_message = DepthImage(
            camera="front", stamp=stamp, sequence=sequence, data=encode_depth_png(depth)
        )
        image = CompressedImage(
            camera="front", stamp=stamp, sequence=sequence, format="png", data=png.tobytes()
        )
        info = CameraInfo(
            camera="front",
            stamp=stamp,
            width=640,
            height=480,
            camera_matrix=[float(v) for v in CALIBRATION.camera_matrix.ravel()],
        )
        for message in (info, depth_message, image):
            writer.write(message.key_for(), message.encode(), int(stamp * 1e9))
    writer.close()


def test_a_recording_replays_frame_by_frame_through_the_pipeline(tmp_path: Path) -> None:
    places = [(0.5, 0.0, 0.02), (0.45, 0.1, 0.02), (0.4, -0.1, 0.02)]
    path = tmp_path / "rgbd.mcap"
    _record(path, places)
    source = open_rgbd_source(str(path))
    assert isinstance(source, McapRgbdSource)
    perception = RgbdPerception(CALIBRATION)
    for sequence, place in enumerate(places):
        frame = source.read()
        assert frame is not None and frame.sequence == sequence
        result = perception.measure(frame.bgr, frame.depth)
        (found,) = result.detections
        assert found.colour == "blue"
        assert np.linalg.norm(found.centre[:2] - place[:2]) < 0.006
    assert source.info is not None and source.info.width == 640
    with pytest.raises(ConfigError, match="ended after 3 RGB-D frames"):
        source.read()
    source.close()


def test_sources_that_cannot_be_opened_are_named() -> None:
    with pytest.raises(ConfigError, match="no such recording"):
        open_rgbd_source("/nonexistent/frames.mcap")
    with pytest.raises(ConfigError, match="not an RGB-D source"):
        open_rgbd_source("/dev/video0")


def test_a_realsense_is_refused_clearly_without_its_package() -> None:
    try:
        import pyrealsense2  # type: ignore[import-not-found]  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("pyrealsense2 is installed here: the refusal is for machines without it")
    with pytest.raises(ConfigError, match="pyrealsense2 package"):
        RealSenseSource()
