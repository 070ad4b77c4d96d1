"""RGB-D frames under hostile input: halves that never pair are let go by count and by age
whatever their sequence numbers do; an oversized depth is refused before it is decoded; an
OpenCV error is a named bad frame."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from synthetic import draw

from manigraph_perception.calibration_file import load_calibration
from manigraph_perception.pairing import UNPAIRED_LIMIT, HalfBuffer
from manigraph_perception.pipeline import BadFrame
from manigraph_perception.pipelines.rgbd.frames import decode_pair
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_shared.messages import CompressedImage, DepthImage
from manigraph_sim.physics.depth_noise import encode_depth_png
from manigraph_testkit.hostile_images import zero_png

ROOT = Path(__file__).resolve().parents[3]
CALIBRATION = load_calibration(ROOT / "examples" / "calibration" / "sim-front.yaml")
NOW = 1_700_000_000.0


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_descending_sequences_never_grow_the_buffer_and_the_camera_s_half_stays() -> None:
    held: HalfBuffer[str] = HalfBuffer()
    held.hold(20_000, "the camera's depth")
    for sequence in range(19_999, 9_999, -1):  # 10,000 forged halves, each older than the last
        held.hold(sequence, "forged")
        assert len(held) <= UNPAIRED_LIMIT
    assert held.dropped == 10_000 - (UNPAIRED_LIMIT - 1)
    assert held.pop(20_000) == "the camera's depth"


def test_a_half_is_let_go_once_it_is_too_old_whatever_its_sequence() -> None:
    clock = Clock()
    held: HalfBuffer[str] = HalfBuffer(max_age=2.0, clock=clock)
    held.hold(10**12, "far ahead of the camera")
    clock.now = 1.0
    held.hold(5, "the camera's")
    assert len(held) == 2
    clock.now = 2.5
    assert held.pop(5) == "the camera's"
    assert held.pop(10**12) is None and held.dropped == 1


def test_a_repeated_sequence_replaces_and_older_halves_go_with_a_whole_frame() -> None:
    held: HalfBuffer[str] = HalfBuffer(max_age=None)
    for sequence in (3, 4, 4, 5):
        held.hold(sequence, f"#{sequence}")
    assert len(held) == 3
    held.drop_older(5)
    assert len(held) == 1 and held.pop(5) == "#5" and held.dropped == 2


def _messages(
    bgr: np.ndarray, depth_png: bytes, sequence: int = 7
) -> tuple[CompressedImage, DepthImage]:
    ok, png = cv2.imencode(".png", bgr)
    assert ok
    image = CompressedImage(
        camera="front", stamp=NOW, sequence=sequence, format="png", data=png.tobytes()
    )
    return image, DepthImage(camera="front", stamp=NOW, sequence=sequence, data=depth_png)


def test_an_oversized_depth_is_refused_by_name_and_never_decoded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    bgr, _ = draw(CALIBRATION, [])
    image, depth = _messages(bgr, zero_png(18000, 18000))
    decoded: list[int] = []
    real = cv2.imdecode

    def imdecode(*args: object) -> object:
        decoded.append(1)
        return real(*args)

    monkeypatch.setattr(cv2, "imdecode", imdecode)
    with pytest.raises(BadFrame) as refused:
        decode_pair(image, depth, CALIBRATION.width, CALIBRATION.height)
    assert refused.value.kind == "wrong_size"
    assert str(refused.value) == (
        "frame 7: depth 18000 x 18000, calibrated for 640 x 480 (refused from its PNG header, "
        "not decoded)"
    )
    assert decoded == []


def test_a_frame_of_the_calibrated_size_decodes() -> None:
    bgr, metres = draw(CALIBRATION, [((0.5, 0.0, 0.02), 0.04, "red")])
    frame = decode_pair(*_messages(bgr, encode_depth_png(metres)), 640, 480)
    assert frame.bgr.shape == (480, 640, 3) and np.allclose(frame.depth, metres)


def test_an_opencv_error_while_measuring_is_a_named_bad_frame() -> None:
    perception = RgbdPerception(CALIBRATION)
    bgr, depth = draw(CALIBRATION, [((0.5, 0.0, 0.02), 0.04, "red")])
    two_channels = np.ascontiguousarray(bgr[..., :2])  # cvtColor(BGR2HSV) asserts 3 channels
    with pytest.raises(BadFrame) as bad:
        perception.process(two_channels, depth, NOW, NOW)
    assert bad.value.kind == "unreadable"
    # OpenCV's text: its source path, a C++ signature of 400 characters, the assertion.
    assert str(bad.value) == "opencv failed measuring the frame: CvtHelper (bad num channels)"
    assert perception.counters.unreadable == 1
    assert "unreadable 1" in perception.counters.summary()
