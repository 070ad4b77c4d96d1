"""Camera calibration: intrinsics from ChArUco board images, extrinsics (camera -> robot base)
from markers at known robot-frame positions.

Extrinsics are a least-squares fit of the markers' centres as the camera sees them (each
posed with ``SOLVEPNP_IPPE_SQUARE``) to where they are in the robot base frame: rigid
(rotation and translation, Kabsch) by default, or affine (12 parameters) as the paper did to
take hardware coordinates into the training frame. Residuals are reported in millimetres.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.detection import detect, detector_for
from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import DICTIONARIES, marker_corners


@dataclass(frozen=True)
class CharucoSpec:
    """A ChArUco board: ``squares`` across x down, square and marker sides in metres."""

    squares_x: int = 7
    squares_y: int = 5
    square: float = 0.04
    marker: float = 0.03
    dictionary: str = "DICT_4X4_50"

    def __post_init__(self) -> None:
        if not (3 <= self.squares_x <= 30 and 3 <= self.squares_y <= 30):
            raise ConfigError("board.squares", "must be 3..30 each way")
        if not 0 < self.marker < self.square <= 0.5:
            raise ConfigError("board.marker", "0 < marker side < square side <= 0.5 m")
        if self.dictionary not in DICTIONARIES:
            raise ConfigError("board.dictionary", f"'{self.dictionary}' is not an OpenCV DICT_*")

    def board(self) -> cv2.aruco.CharucoBoard:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard(
            (self.squares_x, self.squares_y), self.square, self.marker, dictionary
        )


def calibrate_intrinsics(images: list[np.ndarray], spec: CharucoSpec) -> tuple[Calibration, float]:
    """Camera matrix and distortion from grey board images; returns them and the RMS
    reprojection error in pixels. At least 4 views with 6+ corners are needed."""
    board = spec.board()
    detector = cv2.aruco.CharucoDetector(board)
    object_points, image_points = [], []
    for grey in images:
        corners, ids, _, _ = detector.detectBoard(grey)
        if ids is None or len(ids) < 6:
            continue
        # OpenCV's stubs want one array per marker; a ChArUco board's corners are one array.
        objects, pixels = board.matchImagePoints(corners, ids)  # type: ignore[call-overload]
        object_points.append(objects)
        image_points.append(pixels)
    if len(object_points) < 4:
        raise ConfigError(
            "images", f"the board was found in {len(object_points)} images; at least 4 needed"
        )
    height, width = images[0].shape[:2]
    # k3 stays 0: with a handful of views it trades off against the focal length.
    rms, k, distortion, _, _ = cv2.calibrateCamera(
        object_points, image_points, (width, height), None, None, flags=cv2.CALIB_FIX_K3
    )
    return Calibration(k, distortion.ravel(), width, height), float(rms)


@dataclass(frozen=True)
class KnownMarker:
    """A marker whose centre's robot-frame position is known; for the rigid fit also its
    orientation: lying face up, its printed up turned ``yaw`` radians from the robot's +x."""

    id: int
    size: float
    position: np.ndarray
    yaw: float = 0.0

    def corners(self) -> np.ndarray:
        """Its 4 corners in the robot frame, OpenCV's order."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        up = np.array([c, s, 0.0])
        normal = np.array([0.0, 0.0, 1.0])
        rotation = np.stack([np.cross(up, normal), up, normal], axis=1)
        return marker_corners(self.size) @ rotation.T + self.position


def load_known_markers(path: str | Path) -> tuple[str, list[KnownMarker]]:
    """``dictionary = "DICT_4X4_250"`` and ``[[markers]]`` with id, size, position (x y z of
    the marker's centre, metres, robot base frame) and yaw (degrees, default 0: the printed
    marker's up along the robot's +x; markers lie face up)."""
    try:
        data = tomllib.loads(Path(path).read_text())
        known = [
            KnownMarker(
                int(m["id"]),
                float(m["size"]),
                np.array(m["position"], dtype=float),
                float(np.deg2rad(m.get("yaw", 0.0))),
            )
            for m in data["markers"]
        ]
        dictionary = str(data.get("dictionary", "DICT_4X4_250"))
    except OSError as exc:
        raise ConfigError("points", f"cannot read '{path}': {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, KeyError, TypeError, ValueError) as exc:
        raise ConfigError("points", f"'{path}': {exc}") from None
    if dictionary not in DICTIONARIES:
        raise ConfigError("points.dictionary", f"'{dictionary}' is not an OpenCV DICT_*")
    for marker in known:
        if marker.position.shape != (3,) or marker.size <= 0:
            raise ConfigError(f"points.markers.{marker.id}", "needs position [x, y, z], size > 0")
    return dictionary, known


def observe_markers(
    greys: list[np.ndarray], intrinsics: Calibration, dictionary: str, known: list[KnownMarker]
) -> tuple[np.ndarray, np.ndarray]:
    """(camera-frame centres, robot-frame centres) of every known marker seen in each image."""
    detector = detector_for(dictionary)
    by_id = {m.id: m for m in known}
    seen_in_camera, in_base = [], []
    for grey in greys:
        for marker in detect(detector, grey):
            if marker.id not in by_id:
                continue
            spec = by_id[marker.id]
            ok, _, tvec = cv2.solvePnP(
                marker_corners(spec.size),
                marker.corners,
                intrinsics.camera_matrix,
                intrinsics.distortion,
                flags=cv2.SOLVEPNP_IPPE_SQUARE,
            )
            if ok:
                seen_in_camera.append(tvec.ravel())
                in_base.append(spec.position)
    return np.array(seen_in_camera), np.array(in_base)


def fit_transform(camera: np.ndarray, base: np.ndarray, affine: bool = False) -> np.ndarray:
    """base_T_camera (4 x 4) minimising the squared distances; rigid (Kabsch) or affine."""
    needed = 4 if affine else 3
    if len(camera) < needed:
        raise ConfigError("points", f"{len(camera)} markers seen; at least {needed} needed")
    if affine:
        homogeneous = np.hstack([camera, np.ones((len(camera), 1))])
        solution, *_ = np.linalg.lstsq(homogeneous, base, rcond=None)
        transform = np.eye(4)
        transform[:3] = solution.T
        return transform
    camera_mean, base_mean = camera.mean(axis=0), base.mean(axis=0)
    u, _, vt = np.linalg.svd((camera - camera_mean).T @ (base - base_mean))
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    rotation = vt.T @ flip @ u.T
    transform = np.eye(4)
    transform[:3, :3] = rotation
    transform[:3, 3] = base_mean - rotation @ camera_mean
    return transform


def residuals_mm(transform: np.ndarray, camera: np.ndarray, base: np.ndarray) -> np.ndarray:
    mapped = camera @ transform[:3, :3].T + transform[:3, 3]
    return np.linalg.norm(mapped - base, axis=1) * 1000


def fit_camera_pose(
    views: list[tuple[np.ndarray, list[KnownMarker]]], intrinsics: Calibration, dictionary: str
) -> tuple[np.ndarray, np.ndarray]:
    """base_T_camera from the corners of every known flat marker seen in each (image, markers
    where they were for that image), in one PnP (the camera is fixed, so every image
    constrains the same pose); also each corner's distance from its pixel's ray, in
    millimetres (the fit's residuals)."""
    detector = detector_for(dictionary)
    points, pixels = [], []
    for grey, known in views:
        by_id = {m.id: m for m in known}
        for marker in detect(detector, grey):
            if marker.id in by_id:
                points.append(by_id[marker.id].corners())
                pixels.append(marker.corners)
    if len(points) < 2:
        raise ConfigError("points", f"{len(points)} known markers seen; at least 2 needed")
    object_points = np.concatenate(points)
    image_points = np.concatenate(pixels)
    k, d = intrinsics.camera_matrix, intrinsics.distortion
    ok, rvec, tvec = cv2.solvePnP(object_points, image_points, k, d, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise ConfigError("points", "no camera pose fits the markers seen")
    rvec, tvec = cv2.solvePnPRefineLM(object_points, image_points, k, d, rvec, tvec)
    camera_T_base = np.eye(4)
    camera_T_base[:3, :3] = cv2.Rodrigues(rvec)[0]
    camera_T_base[:3, 3] = tvec.ravel()
    # Residuals: each known corner's distance from the ray through the pixel it was seen at.
    in_camera = object_points @ camera_T_base[:3, :3].T + camera_T_base[:3, 3]
    rays = cv2.undistortPoints(image_points.reshape(-1, 1, 2), k, d).reshape(-1, 2)
    rays = np.hstack([rays, np.ones((len(rays), 1))])
    rays = rays / np.linalg.norm(rays, axis=1, keepdims=True)
    along = np.sum(in_camera * rays, axis=1, keepdims=True)
    residuals = np.linalg.norm(in_camera - along * rays, axis=1) * 1000
    return np.linalg.inv(camera_T_base), residuals
