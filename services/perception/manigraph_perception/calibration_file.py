"""A camera's calibration: intrinsics and where it stands, in OpenCV's FileStorage format.

```yaml
%YAML:1.0
---
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix     # K, 3 x 3 (fx 0 cx; 0 fy cy; 0 0 1)
   rows: 3
   cols: 3
   dt: d
   data: [ 415.7, 0., 320., 0., 415.7, 240., 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix   # k1 k2 p1 p2 k3 [k4 k5 k6 ...], 1 x N
   ...
base_T_camera: !!opencv-matrix     # the camera's optical frame in the robot base frame, 4 x 4
   ...
```

``manigraph calibrate intrinsics`` writes the first four, ``manigraph calibrate extrinsics``
adds ``base_T_camera`` (a rigid transform, or an affine one as the paper's hardware setup
used; its last row is always 0 0 0 1).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from manigraph_shared.errors import ConfigError


@dataclass
class Calibration:
    camera_matrix: np.ndarray
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(5))
    width: int = 640
    height: int = 480
    #: Camera optical frame -> robot base frame; None: not calibrated yet.
    base_T_camera: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.camera_matrix = np.asarray(self.camera_matrix, dtype=float)
        self.distortion = np.asarray(self.distortion, dtype=float).reshape(-1)
        k = self.camera_matrix
        if k.shape != (3, 3) or not np.all(np.isfinite(k)):
            raise ConfigError("camera_matrix", "must be a finite 3 x 3 matrix")
        if k[0, 0] <= 0 or k[1, 1] <= 0 or not np.allclose(k[2], [0, 0, 1]):
            raise ConfigError("camera_matrix", "must be [fx 0 cx; 0 fy cy; 0 0 1], fx, fy > 0")
        if self.distortion.size not in (4, 5, 8, 12, 14) or not np.all(
            np.isfinite(self.distortion)
        ):
            raise ConfigError("distortion_coefficients", "must hold 4, 5, 8, 12 or 14 numbers")
        if not (16 <= self.width <= 8192 and 16 <= self.height <= 8192):
            raise ConfigError("image_width", "image size must be in [16, 8192] pixels")
        if self.base_T_camera is not None:
            t = np.asarray(self.base_T_camera, dtype=float)
            if t.shape != (4, 4) or not np.all(np.isfinite(t)):
                raise ConfigError("base_T_camera", "must be a finite 4 x 4 matrix")
            if not np.allclose(t[3], [0, 0, 0, 1]) or abs(np.linalg.det(t[:3, :3])) < 1e-6:
                raise ConfigError("base_T_camera", "last row must be 0 0 0 1, and invertible")
            self.base_T_camera = t

    def save(self, path: str | Path) -> None:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        storage.write("image_width", self.width)
        storage.write("image_height", self.height)
        storage.write("camera_matrix", self.camera_matrix)
        storage.write("distortion_coefficients", self.distortion.reshape(1, -1))
        if self.base_T_camera is not None:
            storage.write("base_T_camera", self.base_T_camera)
        storage.release()


def load_calibration(path: str | Path, need_extrinsics: bool = True) -> Calibration:
    """Read a calibration file; ``ConfigError`` names the missing or bad field."""
    if not Path(path).is_file():
        raise ConfigError("calibration", f"no file '{path}'")
    try:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's parser error surfaces as either
        raise ConfigError("calibration", f"'{path}' is not an OpenCV FileStorage file") from None
    if not storage.isOpened():
        raise ConfigError("calibration", f"cannot open '{path}'")

    def matrix(name: str, required: bool) -> np.ndarray | None:
        node = storage.getNode(name)
        value = None if node.empty() else node.mat()
        if value is None and required:
            raise ConfigError(name, f"missing from '{path}'")
        return value

    try:
        k = matrix("camera_matrix", True)
        assert k is not None  # required: matrix() raised otherwise
        distortion = matrix("distortion_coefficients", False)
        base_T_camera = matrix("base_T_camera", need_extrinsics)
        width = int(storage.getNode("image_width").real() or 640)
        height = int(storage.getNode("image_height").real() or 480)
    finally:
        storage.release()
    return Calibration(
        camera_matrix=k,
        distortion=np.zeros(5) if distortion is None else distortion,
        width=width,
        height=height,
        base_T_camera=base_T_camera,
    )
