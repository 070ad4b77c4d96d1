"""A recorded run's camera channels as Foxglove types (Image panel: image, calibration,
marker annotations)."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import (
    CameraInfo,
    CompressedImage,
    DetectedMarker,
    MarkerDetections,
)
from manigraph_tools.foxglove_camera import (
    export_camera,
    foxglove_annotations,
    marker_label,
    marker_outline,
)

ROOT = Path(__file__).resolve().parents[2]
NOW = 1_700_000_000.25


def _log(path: Path) -> None:
    png = (ROOT / "tests" / "perception" / "frames" / "stack4-start.png").read_bytes()
    messages = [
        CameraInfo(
            camera="front",
            stamp=NOW,
            width=640,
            height=480,
            camera_matrix=[415.7, 0, 319.5, 0, 415.7, 239.5, 0, 0, 1],
        ),
        CompressedImage(camera="front", stamp=NOW, sequence=0, format="png", data=png),
        MarkerDetections(
            camera="front",
            stamp=NOW,
            markers=[
                DetectedMarker(id=0, corners=[10, 10, 30, 10, 30, 30, 10, 30], object_id="b0"),
                DetectedMarker(id=249, corners=[50, 50, 70, 50, 70, 70, 50, 70]),
            ],
        ),
    ]
    writer = McapLogWriter(path)
    for i, message in enumerate(messages):
        writer.write(message.key_for(), message.encode(), int(NOW * 1e9) + i)
    writer.close()


def test_a_log_s_camera_channels_become_foxglove_types(tmp_path: Path) -> None:
    _log(tmp_path / "run.mcap")
    assert export_camera(tmp_path / "run.mcap", tmp_path / "foxglove.mcap") == 3
    with (tmp_path / "foxglove.mcap").open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        schemas = {
            channel.topic: summary.schemas[channel.schema_id].name
            for channel in summary.channels.values()
        }
        images = [m for _, c, m in reader.iter_messages() if c.topic == "/camera/front/image"]
    assert schemas == {
        "/camera/front/image": "foxglove.CompressedImage",
        "/camera/front/calibration": "foxglove.CameraCalibration",
        "/camera/front/markers": "foxglove.ImageAnnotations",
    }
    assert len(images) == 1 and len(images[0].data) > 10_000  # the PNG travelled whole


def test_markers_are_outlined_and_labelled() -> None:
    detections = MarkerDetections(
        camera="front",
        stamp=NOW,
        markers=[DetectedMarker(id=3, corners=[10, 10, 30, 10, 30, 30, 10, 30], object_id="b0")],
    )
    (marker,) = detections.markers
    assert marker_outline(marker)[0] == (10.5, 10.5)  # Foxglove: pixel corner origin
    assert marker_label(marker) == "b0"
    assert marker_label(marker.replace(object_id="")) == "id 3"
    assert foxglove_annotations(detections).encode()  # a valid message
