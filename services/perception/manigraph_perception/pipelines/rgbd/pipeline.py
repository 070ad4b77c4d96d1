"""RGB-D perception as a plain class: a colour image, a depth image and the calibration in,
the ``Scene`` out, no bus (``RgbdPerception``; the service wires it).

Per frame: back-project the depth into the robot base frame (``base_T_camera``), fit the
table plane (``plane.py``) and level the points on it, cut what stands on the table into
objects (``segment.py``), describe each (``objects.py``), match them to the layout's objects
(``tracker.py``; at first sight by appearance, ``identity.py``) and hand their poses to the
same ``WorldModel`` as the ArUco pipeline (object permanence, ``filled`` with hysteresis,
the carried-object rule, ``stale``), without its marker-specific resting (depth measures
height directly).

With ``IdentityMode.APPEARANCE`` (the default) the layout's starting positions are stripped
on the way in: no Scene is given until every object of the layout has been found (``missing``
names those not yet found; the service puts them in its status).

A frame that cannot be used (no table plane, depth of the wrong size, an OpenCV error)
raises ``BadFrame`` naming why; the caller keeps the last good Scene.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.detection import ObjectPose
from manigraph_perception.image_guard import (
    ImageProblem,
    depth_problem,
    opencv_reason,
    size_problem,
)
from manigraph_perception.pipeline import BadFrame, CameraPart, FrameCounters, Observation
from manigraph_perception.pipelines.rgbd.frames import RgbdFrame, decode_pair
from manigraph_perception.pipelines.rgbd.identity import IdentityMode, strip_positions
from manigraph_perception.pipelines.rgbd.objects import (
    CHROMATIC,
    DetectedObject,
    ObjectConfig,
    describe_object,
    palette_hues,
)
from manigraph_perception.pipelines.rgbd.plane import NoTablePlane, Plane, PlaneConfig, fit_table
from manigraph_perception.pipelines.rgbd.segment import SegmentConfig, above_table, segments
from manigraph_perception.pipelines.rgbd.tracker import Tracker
from manigraph_perception.world_belief import WorldConfig, WorldModel
from manigraph_shared.colours import COLOUR_KEYS
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import CompressedImage, DepthImage, Scene, TaskLayout

log = logging.getLogger("manigraph.perception")


@dataclass
class RgbdCounters(FrameCounters):
    no_plane: int = 0
    wrong_size: int = 0
    #: Refused before or while decoding: a header of the wrong size or format, an OpenCV error.
    unreadable: int = 0
    unmatched: int = 0

    def summary(self) -> str:
        return (
            f"frames {self.frames}, no table plane {self.no_plane}, wrong size "
            f"{self.wrong_size}, unreadable {self.unreadable}, unmatched segments "
            f"{self.unmatched}, stale {self.stale}, unpaired halves dropped {self.unpaired}"
        )


@dataclass
class RgbdFrameResult:
    """What one frame gave: the detections (levelled base frame), their matches, the plane
    and the segmentation's labels (for pictures and tests)."""

    plane: Plane
    detections: list[DetectedObject]
    matches: dict[str, DetectedObject]
    labels: np.ndarray = field(repr=False)  # H x W, 0 none, i + 1: detections[i]


class RgbdPerception:
    """Segments, poses and tracks the objects of a layout in RGB-D frames (a
    ``Pipeline[RgbdFrame]``: a frame is a colour image and a depth image of one sequence)."""

    parts: ClassVar[Mapping[str, type[CameraPart]]] = {
        "depth": DepthImage,
        "image": CompressedImage,
    }

    def __init__(
        self,
        calibration: Calibration,
        camera: str = "front",
        world: WorldConfig | None = None,
        seed: int = 0,
        identity: IdentityMode = IdentityMode.APPEARANCE,
    ) -> None:
        if calibration.base_T_camera is None:
            raise ConfigError("calibration.base_T_camera", "missing: run calibrate extrinsics")
        self.calibration = calibration
        self.identity = IdentityMode(identity)
        self.camera = camera
        self.base_T_camera = calibration.base_T_camera
        # Depth measures height directly: no resting along the viewing ray (markers' rule).
        self.world = WorldModel(replace(world or WorldConfig(), rest=None))
        self.plane_config = PlaneConfig()
        self.segment_config = SegmentConfig()
        self.object_config = ObjectConfig()
        self.counters = RgbdCounters()
        self.tracker: Tracker | None = None
        self.vocabulary = palette_hues(CHROMATIC)
        self.plane: Plane | None = None
        self._rng = np.random.default_rng(seed)
        h, w = calibration.height, calibration.width
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        pixels = np.stack([u, v], axis=-1).reshape(-1, 1, 2)
        rays = cv2.undistortPoints(pixels, calibration.camera_matrix, calibration.distortion)
        #: Per pixel, the base-frame direction of its ray scaled to unit optical depth.
        self._rays = np.concatenate([rays.reshape(h, w, 2), np.ones((h, w, 1))], axis=2) @ (
            self.base_T_camera[:3, :3].T
        )

    # --- the episode ------------------------------------------------------------------------
    def set_layout(self, layout: TaskLayout) -> None:
        if self.world.layout is not None and layout.episode_id == self.world.layout.episode_id:
            return
        if self.identity is IdentityMode.APPEARANCE:
            layout = strip_positions(layout)
        self.world.set_layout(layout)
        self.tracker = Tracker(layout)
        named = {
            str(o.attributes[key]).strip().lower()
            for o in layout.objects
            for key in COLOUR_KEYS
            if key in o.attributes
        }
        hues = palette_hues(named)
        self.vocabulary = hues if hues else palette_hues(CHROMATIC)

    @property
    def layout(self) -> TaskLayout | None:
        return self.world.layout

    @property
    def missing(self) -> list[str]:
        """Objects not found yet (``appearance``: no Scene until there are none)."""
        if self.identity is IdentityMode.PRIOR:
            return []
        return [object_id for object_id, belief in self.world.beliefs.items() if not belief.seen]

    # --- frames -----------------------------------------------------------------------------
    def check(self, part: str, data: bytes) -> ImageProblem | None:
        width, height = self.calibration.width, self.calibration.height
        if part == "depth":
            return depth_problem(data, width, height)
        return size_problem("colour image", data, width, height)

    def assemble(self, parts: Mapping[str, CameraPart]) -> RgbdFrame:
        image, depth = parts["image"], parts["depth"]
        assert isinstance(image, CompressedImage) and isinstance(depth, DepthImage)
        return decode_pair(image, depth, self.calibration.width, self.calibration.height)

    def observe(self, frame: RgbdFrame, now: float) -> Observation:
        scene, _ = self.process(frame.bgr, frame.depth, frame.stamp, now)
        waiting, missing = "", self.missing
        if scene is None and missing:  # appearance identity: no Scene until all found
            waiting = f"not found yet: {', '.join(missing[:8])}" + (
                f" and {len(missing) - 8} more" if len(missing) > 8 else ""
            )
        return Observation(scene, waiting=waiting)

    def measure(self, bgr: np.ndarray, depth: np.ndarray) -> RgbdFrameResult:
        """Plane, segments and objects of one frame (``depth`` in metres, 0: none);
        ``BadFrame`` if it cannot be used. Needs no layout; matches only with one."""
        size = (self.calibration.height, self.calibration.width)
        if depth.shape != size or bgr.shape[:2] != size:
            raise BadFrame(
                "wrong_size",
                f"depth {depth.shape[1]} x {depth.shape[0]} and colour {bgr.shape[1]} x "
                f"{bgr.shape[0]}, calibrated for {size[1]} x {size[0]}",
            )
        valid = depth > 0
        rows, cols = np.nonzero(valid)
        if len(rows) < 100:
            raise BadFrame("no_plane", f"no table plane: only {len(rows)} pixels with depth")
        pick = self._rng.integers(0, len(rows), self.plane_config.sample)
        sample = self._points(rows[pick], cols[pick], depth)
        try:
            plane = fit_table(sample, self.plane_config, self._rng, self.plane)
        except NoTablePlane as exc:
            raise BadFrame("no_plane", f"no table plane: {exc}") from None
        self.plane = plane
        # Height over the plane of every pixel's point: depth * (ray . n) + (t . n + offset).
        origin = float(self.base_T_camera[:3, 3] @ plane.normal + plane.offset)
        heights = depth * (self._rays @ plane.normal) + origin
        heights[~valid] = np.nan
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        mask = above_table(heights, depth.astype(np.float32), hsv, self.segment_config)
        level = plane.levelling()
        camera = level[:3, :3] @ self.base_T_camera[:3, 3] + level[:3, 3]
        labels = np.zeros(size, np.int32)
        detections: list[DetectedObject] = []
        for segment in segments(mask, hsv[..., 0], self.segment_config):
            points = self._points(segment.rows, segment.cols, depth)
            found = describe_object(
                points @ level[:3, :3].T + level[:3, 3],
                segment.hue,
                self.vocabulary,
                camera,
                self.object_config,
            )
            if found is not None:
                detections.append(found)
                labels[segment.rows, segment.cols] = len(detections)
        _mark_covered(detections)
        matches: dict[str, DetectedObject] = {}
        if self.tracker is not None:
            # In appearance mode an object has a belief only once found; until then the
            # detections no believed object took are assigned to it by what it looks like.
            prior = self.identity is IdentityMode.PRIOR
            believed = {
                object_id: belief.position
                for object_id, belief in self.world.beliefs.items()
                if prior or belief.seen
            }
            matches = dict(self.tracker.match(detections, believed))
            unfound = [object_id for object_id in self.world.beliefs if object_id not in believed]
            if unfound:
                taken = {id(d) for d in matches.values()}
                left = [d for d in detections if id(d) not in taken]
                matches.update(self.tracker.acquire(left, unfound))
            self.counters.unmatched += len(detections) - len(matches)
        return RgbdFrameResult(plane, detections, matches, labels)

    def _points(self, rows: np.ndarray, cols: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Base-frame points of these pixels (N x 3)."""
        return self._rays[rows, cols] * depth[rows, cols, None] + self.base_T_camera[:3, 3]

    def process(
        self, bgr: np.ndarray, depth: np.ndarray, stamp: float, now: float
    ) -> tuple[Scene | None, RgbdFrameResult]:
        """One frame: the Scene (None before a layout) and what was measured; ``BadFrame``
        (counted) if the frame cannot be used."""
        self.counters.frames += 1
        try:
            try:
                result = self.measure(bgr, depth)
            except cv2.error as exc:
                raise BadFrame("unreadable", opencv_reason(exc, "measuring the frame")) from None
        except BadFrame as exc:
            self.count(exc)
            raise
        if self.tracker is None:
            return None, result
        self.world.update([self._pose(i, d) for i, d in result.matches.items()], stamp)
        for object_id, detection in result.matches.items():
            if object_id in self.tracker.colours:
                self.world.attributes[object_id]["colour"] = detection.colour
        if self.missing:
            return None, result  # no Scene with an object nowhere
        scene = self.world.scene(stamp, now)
        if scene is not None and scene.stale:
            self.counters.stale += 1
        return scene, result

    def count(self, problem: BadFrame) -> None:
        """Count ``problem`` under its kind."""
        self.counters.count(problem.kind)

    def _pose(self, object_id: str, detection: DetectedObject) -> ObjectPose:
        assert self.tracker is not None
        size = self.tracker.sizes[object_id]
        centre = detection.centre - np.array([0.0, 0.0, size[2] / 2])
        belief = self.world.beliefs[object_id]
        if detection.covered and (belief.seen or self.identity is IdentityMode.PRIOR):
            # Something stands on it: only a part of its side shows, which says it is there,
            # not exactly where (the top of what shows may be well below its own). It is
            # kept where it was believed when its top was last seen (found under another,
            # never seen whole: where its side says, half its depth behind it).
            centre = belief.position.copy()
        elif not detection.covered:
            centre[:2] += detection.away * _far_edge_loss(detection, size) / 2
        pose = np.eye(4)
        c, s = np.cos(detection.yaw), np.sin(detection.yaw)
        pose[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        pose[:3, 3] = centre
        return ObjectPose(object_id, pose, markers=0, reprojection_px=0.0)


def _far_edge_loss(detection: DetectedObject, size: np.ndarray) -> float:
    """How much of the top face's far edge (seen against the background, at a depth step)
    the segmentation lost: the footprint's expected extent along the viewing direction
    less the measured one (at most a quarter of the object)."""
    c, s = np.cos(detection.yaw), np.sin(detection.yaw)
    u = detection.away
    expected = abs(size[0] * (c * u[0] + s * u[1])) + abs(size[1] * (-s * u[0] + c * u[1]))
    return float(np.clip(expected - detection.extent_away, 0.0, expected / 4))


def _mark_covered(detections: list[DetectedObject]) -> None:
    """A detection with another standing on it (its bottom at this one's top, over it) is
    covered, whatever its top's outline says."""
    for lower in detections:
        for upper in detections:
            if (
                upper is not lower
                and abs(upper.bottom - lower.top) < 0.015
                and np.linalg.norm(upper.centre[:2] - lower.centre[:2]) < 0.05
            ):
                lower.covered = True
