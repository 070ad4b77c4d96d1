"""RGB-D frames drawn analytically (no renderer): a table at z = 0 and axis-aligned boxes,
seen by the sim camera's exact calibration. Each pixel's ray meets the nearest surface."""

from __future__ import annotations

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_shared.colours import PALETTE

TABLE_BGR = (97, 128, 158)  # the sim's table, as rendered (beige, little saturation)


def draw(
    calibration: Calibration, boxes: list[tuple[tuple[float, float, float], float, str]]
) -> tuple[np.ndarray, np.ndarray]:
    """(bgr, depth in metres) of ``boxes``: (centre, side, palette colour) cubes."""
    assert calibration.base_T_camera is not None
    h, w = calibration.height, calibration.width
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    k_inv = np.linalg.inv(calibration.camera_matrix)
    rays = np.stack([u, v, np.ones_like(u)], axis=-1) @ k_inv.T  # optical depth 1
    rays = rays @ calibration.base_T_camera[:3, :3].T
    origin = calibration.base_T_camera[:3, 3]
    depth = np.where(rays[..., 2] < 0, -origin[2] / np.minimum(rays[..., 2], -1e-9), np.inf)
    bgr = np.empty((h, w, 3), np.uint8)
    bgr[:] = TABLE_BGR
    for centre, side, colour in boxes:
        low, high = np.array(centre) - side / 2, np.array(centre) + side / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (low - origin) / rays, (high - origin) / rays
        near = np.nanmax(np.minimum(t1, t2), axis=-1)
        far = np.nanmin(np.maximum(t1, t2), axis=-1)
        hit = (near <= far) & (near > 0) & (near < depth)
        depth[hit] = near[hit]
        r, g, b = PALETTE[colour]
        face = np.argmax(np.minimum(t1, t2), axis=-1)  # the axis of the face hit
        shade = np.array([0.8, 0.7, 1.0])[face]  # sides darker than the top
        for channel, value in enumerate((b, g, r)):
            bgr[..., channel][hit] = np.round(value * 255 * shade[hit]).astype(np.uint8)
    depth[~np.isfinite(depth)] = 0.0
    return bgr, np.round(depth * 1000) / 1000


def blank(calibration: Calibration) -> tuple[np.ndarray, np.ndarray]:
    bgr, depth = draw(calibration, [])
    return cv2.GaussianBlur(bgr, (3, 3), 0), depth
