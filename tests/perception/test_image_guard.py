"""Images checked from their header before they are decoded, and OpenCV's errors named: the
630 kB PNG of 18000 x 18000 zeros (issue 48) is refused by name and never decoded."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.image_guard import (
    ImageHeader,
    UnreadableHeader,
    depth_problem,
    opencv_reason,
    read_header,
    size_problem,
)
from manigraph_perception.pipeline import BadFrame
from manigraph_perception.pipelines.aruco.pipeline import Perception
from manigraph_shared.markers import MarkerMap
from manigraph_shared.messages import CompressedImage
from manigraph_testkit.hostile_images import zero_png

NOW = 1_700_000_000.0


@pytest.fixture
def perception(markers: MarkerMap, calibration: Calibration) -> Perception:
    return Perception(markers, calibration)


def _encode(ext: str, image: np.ndarray, *params: int) -> bytes:
    ok, data = cv2.imencode(ext, image, list(params))
    assert ok
    return data.tobytes()


@pytest.fixture
def no_decoding(monkeypatch: pytest.MonkeyPatch) -> None:
    """Any decode fails the test: a refusal must come from the header alone."""

    def imdecode(*_: object) -> None:
        raise AssertionError("the image was decoded")

    monkeypatch.setattr(cv2, "imdecode", imdecode)


def test_headers_say_the_size_and_sample_format_of_real_images() -> None:
    depth = np.zeros((480, 640), np.uint16)
    colour = np.zeros((480, 640, 3), np.uint8)
    assert read_header(_encode(".png", depth)) == ImageHeader("png", 640, 480, 16, 1)
    assert read_header(_encode(".png", colour)) == ImageHeader("png", 640, 480, 8, 3)
    assert read_header(_encode(".jpg", colour)) == ImageHeader("jpeg", 640, 480, 8, 3)
    progressive = _encode(".jpg", colour, cv2.IMWRITE_JPEG_PROGRESSIVE, 1)
    assert read_header(progressive) == ImageHeader("jpeg", 640, 480, 8, 3)
    assert read_header(zero_png(18000, 18000)) == ImageHeader("png", 18000, 18000, 16, 1)


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (b"", "neither PNG nor JPEG (starts empty)"),
        (b"GIF89a....", "neither PNG nor JPEG (starts 47 49 46 38)"),
        (zero_png(64, 64)[:20], "PNG truncated before its IHDR chunk"),
        (b"\xff\xd8xx", "JPEG without a frame header"),
        (b"\xff\xd8\xff\xda\x00\x08" + bytes(8), "JPEG without a frame header"),
    ],
)
def test_a_header_that_does_not_say_its_size_is_named(data: bytes, words: str) -> None:
    with pytest.raises(UnreadableHeader, match=words.replace("(", r"\(").replace(")", r"\)")):
        read_header(data)


@pytest.mark.usefixtures("no_decoding")
def test_the_630_kb_depth_of_18000_x_18000_is_refused_from_its_header() -> None:
    data = zero_png(18000, 18000)
    assert len(data) < 700_000  # within the message's limit: only its header can refuse it
    problem = depth_problem(data, 640, 480)
    assert problem is not None and problem.kind == "wrong_size"
    assert problem.reason == (
        "depth 18000 x 18000, calibrated for 640 x 480 (refused from its PNG header, not decoded)"
    )
    small = _encode(".jpg", np.zeros((10, 20, 3), np.uint8))
    colour = size_problem("colour image", small, 640, 480)
    assert colour is not None and colour.reason.startswith("colour image 20 x 10, calibrated")


def test_depth_must_be_16_bit_grey_png() -> None:
    eight_bit = depth_problem(zero_png(640, 480, bit_depth=8), 640, 480)
    assert eight_bit is not None and eight_bit.kind == "unreadable"
    assert "8-bit PNG of 1 channel(s), not the 16-bit grey PNG" in eight_bit.reason
    jpeg = depth_problem(_encode(".jpg", np.zeros((480, 640), np.uint8)), 640, 480)
    assert jpeg is not None and "not the 16-bit grey PNG" in jpeg.reason
    assert depth_problem(zero_png(640, 480), 640, 480) is None


def test_an_opencv_error_is_named_without_its_source_or_assertion_text() -> None:
    with pytest.raises(cv2.error) as raised:
        cv2.cvtColor(np.zeros((0, 0), np.uint8), cv2.COLOR_BGR2HSV)
    reason = opencv_reason(raised.value, "measuring the frame")
    assert reason == "opencv failed measuring the frame: cvtColor (assertion failed)"
    assert "!_src.empty()" in str(raised.value)  # what is left out


@pytest.mark.usefixtures("no_decoding")
def test_the_marker_pipeline_refuses_an_oversized_image_without_decoding_it(
    perception: Perception,
) -> None:
    huge = CompressedImage(
        camera="front", stamp=NOW, sequence=3, format="png", data=zero_png(18000, 18000, 8)
    )
    assert perception.process_image(huge, NOW) == (None, None)
    assert perception.counters.corrupt == 1


def test_an_opencv_error_in_marker_detection_refuses_the_frame_by_name(
    perception: Perception, monkeypatch: pytest.MonkeyPatch
) -> None:
    def detect(*_: object) -> None:
        cv2.cvtColor(np.zeros((0, 0), np.uint8), cv2.COLOR_BGR2HSV)

    monkeypatch.setattr("manigraph_perception.pipelines.aruco.pipeline.detect", detect)
    with pytest.raises(BadFrame) as refused:
        perception.process(np.zeros((480, 640), np.uint8), NOW, NOW)
    assert refused.value.kind == "corrupt" and perception.counters.corrupt == 1
    assert str(refused.value) == "opencv failed detecting markers: cvtColor (assertion failed)"
    assert "color.cpp" not in str(refused.value)
