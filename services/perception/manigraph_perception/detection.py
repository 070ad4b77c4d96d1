"""Markers in an image -> object poses in the robot base frame.

Each marker is found with OpenCV's ``ArucoDetector`` (corners refined to subpixel accuracy)
and posed with ``solvePnP``'s ``SOLVEPNP_IPPE_SQUARE``; the markers of one object are then
fused: the best-fitting marker's pose (of IPPE's two solutions, the one that reprojects the
object's other markers best) starts one Levenberg-Marquardt refinement over the corners of all
its markers, so an object seen on two or three faces is posed from points that are not
coplanar (much better in depth, the weak direction of a single small marker).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.deblur import MIN_BLUR_PX, BlurGauge, wiener
from manigraph_shared.markers import MarkerMap, marker_corners, marker_in_object


@dataclass(frozen=True)
class Marker:
    """One detected marker: its id and its 4 image corners (4 x 2, OpenCV's order)."""

    id: int
    corners: np.ndarray


@dataclass(frozen=True)
class ObjectPose:
    """An object's pose in the robot base frame, from ``markers`` of its markers."""

    object_id: str
    base_T_object: np.ndarray
    markers: int
    reprojection_px: float


class Detectors(NamedTuple):
    """OpenCV's detector for the image, a cheaper one for the image enlarged twice (one
    adaptive-threshold window instead of three: the same markers at 40% of the cost), and the
    gauge of motion blur (``deblur.py``)."""

    normal: cv2.aruco.ArucoDetector
    enlarged: cv2.aruco.ArucoDetector
    gauge: BlurGauge | None = None


def detector_for(markers: MarkerMap | str) -> Detectors:
    name = markers if isinstance(markers, str) else markers.dictionary
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
    detectors = []
    for window in (None, 13):
        parameters = cv2.aruco.DetectorParameters()
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        parameters.cornerRefinementWinSize = 3
        if window is not None:
            parameters.adaptiveThreshWinSizeMin = window
            parameters.adaptiveThreshWinSizeMax = window
        detectors.append(cv2.aruco.ArucoDetector(dictionary, parameters))
    return Detectors(detectors[0], detectors[1], BlurGauge(dictionary))


#: Subpixel corner refinement finds a black square's corners this far inside the true ones
#: on a slightly blurred image (measured on the rendered camera: 0.37-0.49 px for markers of
#: 15-19 px, whatever their size); :func:`detect` moves them back out.
CORNER_BIAS_PX = 0.43
#: Markers of 13-15 px (a 3.4 cm marker 0.75 m away, seen at a slant) are found only on the
#: image enlarged twice; their corners from there have a smaller bias (measured).
UPSCALED_CORNER_BIAS_PX = 0.3


def detect(
    detector: Detectors,
    grey: np.ndarray,
    corner_bias: float = CORNER_BIAS_PX,
    upscale: bool = True,
) -> list[Marker]:
    """Markers found in ``grey``; with ``upscale``, also those found only in the image
    enlarged twice (about twice the cost); with the detector's blur gauge, when the markers
    found show a motion blur, also those found once it is undone."""
    markers = _detect(detector.normal, grey, 1, corner_bias)
    if upscale:
        markers += _missing(markers, _detect_enlarged(detector, grey))
    if detector.gauge is not None and markers:
        blur = detector.gauge.measure(grey, [(m.id, m.corners) for m in markers])
        if blur is not None and blur.length >= MIN_BLUR_PX:
            sharp = wiener(grey, blur)
            again = _detect(detector.normal, sharp, 1, corner_bias)
            if upscale:
                again += _missing(again, _detect_enlarged(detector, sharp))
            markers = again + _missing(again, markers)
    return markers


def _missing(found: list[Marker], more: list[Marker]) -> list[Marker]:
    """The markers of ``more`` whose id is not in ``found``."""
    ids = {m.id for m in found}
    return [m for m in more if m.id not in ids]


def _detect_enlarged(detector: Detectors, grey: np.ndarray) -> list[Marker]:
    big = cv2.resize(grey, None, fx=2, fy=2, interpolation=cv2.INTER_LINEAR)
    return _detect(detector.enlarged, big, 2, UPSCALED_CORNER_BIAS_PX)


def _detect(
    detector: cv2.aruco.ArucoDetector, grey: np.ndarray, scale: int, corner_bias: float
) -> list[Marker]:
    corners, ids, _ = detector.detectMarkers(grey)
    if ids is None:
        return []
    markers = []
    for i, c in zip(ids.ravel(), corners, strict=True):
        # Pixel centres: i in the enlarged image is (i + 0.5) / scale - 0.5 in the original.
        points = (np.asarray(c, dtype=float).reshape(4, 2) + 0.5) / scale - 0.5
        outward = points - points.mean(axis=0)
        outward /= np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-9)
        markers.append(Marker(int(i), points + corner_bias * outward))
    return markers


class ObjectPoser:
    """Poses the objects of a marker map from detected markers (unknown ids are skipped:
    the caller warns about them)."""

    def __init__(self, markers: MarkerMap, calibration: Calibration, object_sizes: dict) -> None:
        if calibration.base_T_camera is None:
            raise ValueError("calibration has no base_T_camera")
        self.calibration = calibration
        self.specs = markers.by_id()
        #: marker id -> its 4 corners in its object's frame (4 x 3)
        self.corners_in_object: dict[int, np.ndarray] = {}
        for marker_id, spec in self.specs.items():
            if spec.object not in object_sizes:
                continue  # not in this episode's layout
            pose = marker_in_object(spec, object_sizes[spec.object])
            local = marker_corners(spec.size)
            self.corners_in_object[marker_id] = local @ pose[:3, :3].T + pose[:3, 3]

    def poses(self, markers: list[Marker]) -> list[ObjectPose]:
        by_object: dict[str, list[Marker]] = {}
        for marker in markers:
            if marker.id in self.corners_in_object:
                by_object.setdefault(self.specs[marker.id].object, []).append(marker)
        return [self._pose(object_id, seen) for object_id, seen in by_object.items()]

    def _pose(self, object_id: str, seen: list[Marker]) -> ObjectPose:
        k, d = self.calibration.camera_matrix, self.calibration.distortion
        object_points = np.concatenate([self.corners_in_object[m.id] for m in seen])
        image_points = np.concatenate([m.corners for m in seen])
        base_T_camera = self.calibration.base_T_camera
        assert base_T_camera is not None
        candidates: list[tuple[float, float, np.ndarray, np.ndarray]] = []
        for marker in seen:
            spec = self.specs[marker.id]
            _, rvecs, tvecs, _ = cv2.solvePnPGeneric(
                marker_corners(spec.size), marker.corners, k, d, flags=cv2.SOLVEPNP_IPPE_SQUARE
            )
            object_T_marker = marker_in_object(spec, np.zeros(3))
            for rvec, tvec in zip(rvecs, tvecs, strict=True):
                cam_T_object = _matrix(rvec, tvec) @ _inverse(
                    _marker_transform(self.corners_in_object[marker.id], spec.size, object_T_marker)
                )
                r, t = _vectors(cam_T_object)
                error = _reprojection(object_points, image_points, r, t, k, d)
                upright = _resting(base_T_camera[:3, :3] @ cam_T_object[:3, :3])
                candidates.append((error, upright, r, t))
        # A small marker seen at a slant has two poses that fit its corners almost equally
        # (IPPE's ambiguity); the wrong one tilts the object and moves its centre by up to a
        # block's width. Of the poses that fit about as well as the best, take the one that
        # rests like a box on a table (an axis vertical).
        best_error = min(c[0] for c in candidates)
        fitting = [c for c in candidates if c[0] <= 1.5 * best_error + AMBIGUOUS_PX]
        error, _, rvec, tvec = max(fitting, key=lambda c: c[1])
        if len(seen) > 1:
            rvec, tvec = cv2.solvePnPRefineLM(object_points, image_points, k, d, rvec, tvec)
            error = _reprojection(object_points, image_points, rvec, tvec, k, d)
        return ObjectPose(object_id, base_T_camera @ _matrix(rvec, tvec), len(seen), error)


#: Poses whose reprojection error is within this (and 1.5x) of the best fit equally well.
AMBIGUOUS_PX = 0.3


def _resting(rotation: np.ndarray) -> float:
    """1 when one of the object's axes is vertical (a box resting on a face), less tilted."""
    return float(np.max(np.abs(rotation[2])))


def _marker_transform(corners: np.ndarray, size: float, rotation: np.ndarray) -> np.ndarray:
    """object_T_marker from the marker's corners in the object frame (its centre is their
    mean) and the face rotation."""
    transform = rotation.copy()
    transform[:3, 3] = corners.mean(axis=0)
    return transform


def _matrix(rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
    transform = np.eye(4)
    transform[:3, :3] = cv2.Rodrigues(np.asarray(rvec, dtype=float))[0]
    transform[:3, 3] = np.asarray(tvec, dtype=float).ravel()
    return transform


def _vectors(transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return cv2.Rodrigues(transform[:3, :3])[0], transform[:3, 3].reshape(3, 1).copy()


def _inverse(transform: np.ndarray) -> np.ndarray:
    inverse = np.eye(4)
    inverse[:3, :3] = transform[:3, :3].T
    inverse[:3, 3] = -transform[:3, :3].T @ transform[:3, 3]
    return inverse


def _reprojection(
    points: np.ndarray,
    pixels: np.ndarray,
    rvec: np.ndarray,
    tvec: np.ndarray,
    k: np.ndarray,
    d: np.ndarray,
) -> float:
    projected, _ = cv2.projectPoints(points, rvec, tvec, k, d)
    return float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - pixels) ** 2, axis=1))))
