"""Camera messages as Foxglove's well-known types, so Foxglove's Image panel shows a run.

For the lead: the 3D scene's conversions live in ``foxglove_scene.py`` (another branch);
these are the camera's, kept apart so the two merge without conflict. ``export_camera``
writes the camera channels of a recorded log as a Foxglove MCAP; the recorder (or the scene
exporter) can call the three ``foxglove_*`` functions per message instead.

* ``CompressedImage``  -> ``foxglove.CompressedImage`` on ``/camera/<name>/image``
* ``CameraInfo``       -> ``foxglove.CameraCalibration`` on ``/camera/<name>/calibration``
* ``MarkerDetections`` -> ``foxglove.ImageAnnotations`` on ``/camera/<name>/markers``
  (each marker's outline, and its object, or its id if unknown, as a label)
"""

from __future__ import annotations

from pathlib import Path

from foxglove import open_mcap
from foxglove.channels import (
    CameraCalibrationChannel,
    CompressedImageChannel,
    ImageAnnotationsChannel,
)
from foxglove.messages import (
    CameraCalibration,
    Color,
    ImageAnnotations,
    Point2,
    PointsAnnotation,
    PointsAnnotationType,
    TextAnnotation,
    Timestamp,
)
from foxglove.messages import CompressedImage as FoxgloveImage

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import (
    CameraInfo,
    CompressedImage,
    DetectedMarker,
    MarkerDetections,
)

KNOWN = Color(r=0.15, g=0.85, b=0.15, a=1.0)
UNKNOWN = Color(r=0.9, g=0.15, b=0.15, a=1.0)


def _timestamp(stamp: float) -> Timestamp:
    seconds = int(stamp)
    return Timestamp(sec=seconds, nsec=round((stamp - seconds) * 1e9) % 1_000_000_000)


def foxglove_image(image: CompressedImage) -> FoxgloveImage:
    return FoxgloveImage(
        timestamp=_timestamp(image.stamp),
        frame_id=image.camera,
        data=image.data,
        format=image.format.value,
    )


def foxglove_calibration(info: CameraInfo) -> CameraCalibration:
    k = list(info.camera_matrix)
    # Projection of an unrectified camera: P = [K | 0].
    p = [k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0]
    distortion = list(info.distortion)
    return CameraCalibration(
        timestamp=_timestamp(info.stamp),
        frame_id=info.camera,
        width=info.width,
        height=info.height,
        distortion_model="plumb_bob" if len(distortion) <= 5 else "rational_polynomial",
        D=distortion,
        K=k,
        R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        P=p,
    )


def marker_outline(marker: DetectedMarker) -> list[tuple[float, float]]:
    """The marker's corners in Foxglove's pixel coordinates (origin at the top-left pixel's
    corner; OpenCV's is its centre: +0.5)."""
    return [(marker.corners[2 * i] + 0.5, marker.corners[2 * i + 1] + 0.5) for i in range(4)]


def marker_label(marker: DetectedMarker) -> str:
    return marker.object_id or f"id {marker.id}"


def foxglove_annotations(detections: MarkerDetections) -> ImageAnnotations:
    """Each marker's outline, and its label above it."""
    points, texts = [], []
    for marker in detections.markers:
        outline = marker_outline(marker)
        corners = [Point2(x=x, y=y) for x, y in outline]
        colour = KNOWN if marker.object_id else UNKNOWN
        points.append(
            PointsAnnotation(
                timestamp=_timestamp(detections.stamp),
                type=PointsAnnotationType.LineLoop,
                points=corners,
                outline_color=colour,
                thickness=1.5,
            )
        )
        texts.append(
            TextAnnotation(
                timestamp=_timestamp(detections.stamp),
                position=Point2(x=min(x for x, _ in outline), y=min(y for _, y in outline) - 2),
                text=marker_label(marker),
                font_size=11.0,
                text_color=colour,
            )
        )
    return ImageAnnotations(timestamp=_timestamp(detections.stamp), points=points, texts=texts)


def export_camera(log: Path, output: Path) -> int:
    """Write the camera channels of manigraph log ``log`` as Foxglove types into ``output``;
    returns the number of messages written."""
    written = 0
    with open_mcap(output, allow_overwrite=True):
        images: dict[str, CompressedImageChannel] = {}
        calibrations: dict[str, CameraCalibrationChannel] = {}
        annotations: dict[str, ImageAnnotationsChannel] = {}
        for logged in read_log(log, ["manigraph/camera/**"]):
            message = logged.decode()
            if isinstance(message, CompressedImage):
                topic = f"/camera/{message.camera}/image"
                channel = images.setdefault(topic, CompressedImageChannel(topic))
                channel.log(foxglove_image(message), log_time=logged.log_time_ns)
            elif isinstance(message, CameraInfo):
                topic = f"/camera/{message.camera}/calibration"
                calibration = calibrations.setdefault(topic, CameraCalibrationChannel(topic))
                calibration.log(foxglove_calibration(message), log_time=logged.log_time_ns)
            elif isinstance(message, MarkerDetections):
                topic = f"/camera/{message.camera}/markers"
                annotation = annotations.setdefault(topic, ImageAnnotationsChannel(topic))
                annotation.log(foxglove_annotations(message), log_time=logged.log_time_ns)
            else:
                continue
            written += 1
    return written
