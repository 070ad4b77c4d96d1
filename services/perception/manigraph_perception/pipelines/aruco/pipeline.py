"""The ArUco pipeline as a plain class: an image in, a ``Scene`` and the detected markers out.

No bus here (``manigraph_perception.service`` runs it, as every pipeline): every step takes
and returns values or contract messages, so it is tested on rendered images directly. A frame
is one image (``parts``); any frame that cannot be used is counted as ``corrupt``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.detection import ObjectPoser, detect, detector_for
from manigraph_perception.image_guard import ImageProblem, opencv_reason, size_problem
from manigraph_perception.pipeline import BadFrame, CameraPart, FrameCounters, Observation
from manigraph_perception.world_belief import WorldConfig, WorldModel
from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import MarkerMap
from manigraph_shared.messages import (
    CompressedImage,
    DetectedMarker,
    MarkerDetections,
    Scene,
    TaskLayout,
)

log = logging.getLogger("manigraph.perception")


@dataclass
class Counters(FrameCounters):
    """What the service reports in its status."""

    corrupt: int = 0
    unknown_markers: set[int] = field(default_factory=set)

    def count(self, kind: str) -> None:
        self.corrupt += 1  # any frame refused, whatever its kind

    def summary(self) -> str:
        return (
            f"frames {self.frames}, corrupt {self.corrupt} skipped, stale {self.stale}, "
            f"unknown marker ids {sorted(self.unknown_markers)[:10]}"
        )


@dataclass
class GreyFrame:
    grey: np.ndarray  # H x W uint8
    stamp: float
    sequence: int = 0


class Perception:
    """Detects markers, poses objects, keeps the world model (a ``Pipeline[GreyFrame]``)."""

    parts: ClassVar[Mapping[str, type[CameraPart]]] = {"image": CompressedImage}

    def __init__(
        self,
        markers: MarkerMap,
        calibration: Calibration,
        camera: str = "front",
        world: WorldConfig | None = None,
    ) -> None:
        if calibration.base_T_camera is None:
            raise ConfigError("calibration.base_T_camera", "missing: run calibrate extrinsics")
        self.markers = markers
        self.calibration = calibration
        self.camera = camera
        self.detector = detector_for(markers)
        self.world = WorldModel(world, calibration.base_T_camera[:3, 3])
        self.poser: ObjectPoser | None = None
        self.known_ids = set(markers.by_id())
        self.counters = Counters()

    def set_layout(self, layout: TaskLayout) -> None:
        """Take a new episode's layout; ``ConfigError`` names an object with no marker."""
        if self.world.layout is not None and layout.episode_id == self.world.layout.episode_id:
            return
        self.markers.check_objects((o.id, o.category.value) for o in layout.objects)
        sizes = {o.id: np.array(o.size.as_tuple()) for o in layout.objects}
        self.poser = ObjectPoser(self.markers, self.calibration, sizes)
        self.world.set_layout(
            layout, {o.id: self.markers.attributes_of(o.id) for o in layout.objects}
        )

    @property
    def layout(self) -> TaskLayout | None:
        return self.world.layout

    def check(self, part: str, data: bytes) -> ImageProblem | None:
        return size_problem(part, data, self.calibration.width, self.calibration.height)

    def assemble(self, parts: Mapping[str, CameraPart]) -> GreyFrame:
        """The grey image of a frame; ``BadFrame`` if it does not decode or has the wrong
        size (the size is read from the header first: an oversized image is never decoded)."""
        image = parts["image"]
        width, height = self.calibration.width, self.calibration.height
        problem = self.check("image", image.data)
        grey = None
        if problem is None:
            try:
                grey = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_GRAYSCALE)
            except cv2.error as exc:
                problem = ImageProblem("unreadable", opencv_reason(exc, "decoding it"))
        if problem is None and (grey is None or grey.shape != (height, width)):
            problem = ImageProblem("unreadable", "image does not decode")
        if problem is not None:
            raise BadFrame("corrupt", f"frame {image.sequence}: {problem.reason}")
        assert grey is not None
        return GreyFrame(grey, image.stamp, image.sequence)

    def decode(self, image: CompressedImage) -> np.ndarray | None:
        """The grey image, or None (counted, logged) if it cannot be a frame."""
        try:
            return self.assemble({"image": image}).grey
        except BadFrame as exc:
            self.counters.count(exc.kind)
            log.warning("frame skipped: %s", exc)
            return None

    def observe(self, frame: GreyFrame, now: float) -> Observation:
        scene, detections = self.process(frame.grey, frame.stamp, now)
        return Observation(scene, [detections])

    def process(
        self, grey: np.ndarray, stamp: float, now: float
    ) -> tuple[Scene | None, MarkerDetections]:
        """One frame: the Scene (None before a layout) and what was detected; ``BadFrame``
        (counted) if OpenCV fails on it."""
        self.counters.frames += 1
        try:
            found = detect(self.detector, grey)
        except cv2.error as exc:
            self.counters.count("corrupt")
            raise BadFrame("corrupt", opencv_reason(exc, "detecting markers")) from None
        for marker in found:
            if marker.id not in self.known_ids and marker.id not in self.counters.unknown_markers:
                self.counters.unknown_markers.add(marker.id)
                log.warning("marker id %d is not in the marker map: ignored", marker.id)
        specs = self.markers.by_id()
        detections = MarkerDetections(
            camera=self.camera,
            stamp=stamp,
            markers=[
                DetectedMarker(
                    id=m.id,
                    corners=[float(v) for v in m.corners.ravel()],
                    object_id=specs[m.id].object if m.id in specs else "",
                )
                for m in found
            ],
        )
        if self.poser is None:
            return None, detections
        self.world.update(self.poser.poses(found), stamp)
        scene = self.world.scene(stamp, now)
        if scene is not None and scene.stale:
            self.counters.stale += 1
        return scene, detections

    def process_image(
        self, image: CompressedImage, now: float
    ) -> tuple[Scene | None, MarkerDetections | None]:
        """One bus image: as :meth:`process`, or (None, None) if it cannot be used (counted,
        logged)."""
        grey = self.decode(image)
        if grey is None:
            return None, None
        try:
            return self.process(grey, image.stamp, now)
        except BadFrame as exc:
            log.warning("frame skipped: %s", exc)
            return None, None


def draw_detections(bgr: np.ndarray, detections: MarkerDetections) -> np.ndarray:
    """``bgr`` with every detected marker outlined and labelled (its object, or its id)."""
    out = bgr.copy()
    for marker in detections.markers:
        corners = np.array(marker.corners).reshape(4, 2)
        colour = (40, 220, 40) if marker.object_id else (40, 40, 230)
        cv2.polylines(out, [np.round(corners).astype(np.int32)], True, colour, 1, cv2.LINE_AA)
        label = marker.object_id.replace("block_", "b").replace("cover_", "c") or str(marker.id)
        x, y = corners.min(axis=0)
        cv2.putText(
            out, label, (int(x), int(y) - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.35, colour, 1, cv2.LINE_AA
        )
    return out
