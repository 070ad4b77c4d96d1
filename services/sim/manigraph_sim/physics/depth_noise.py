"""A stereo depth sensor's errors, applied to a rendered (perfect) depth image.

Modelled on an Intel RealSense D400 (D435: 50 mm baseline, ~0.08 px subpixel disparity
error), whose RMS depth error grows with the square of the distance:

    sigma(z) = z^2 * subpixel / (f * baseline)

which is 0.0042 m^-1 * z^2 at its 640 x 480 depth focal length: 1.1 mm at 0.5 m, 2.7 mm at
0.8 m, 4.2 mm at 1 m (Intel's "Depth camera tuning" white paper, figure "RMS error vs
distance"). Besides that noise:

* **edge dropout**: a stereo matcher finds no disparity where a pixel straddles a depth
  step (the two cameras see different surfaces there); such pixels are 0 ("no depth") with
  probability ``edge_dropout``;
* **holes**: blobs with no depth (specular spots, texture-less patches, shadows of the
  projector): ``holes`` ellipses of 3-12 px per frame, placed at random;
* **range**: nothing nearer than ``min_range`` or beyond ``max_range``;
* **quantisation**: the sensor's 1 mm unit (the 16-bit PNG of the contract's ``DepthImage``).

All draws come from the generator given, so a seeded camera gives the same frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from manigraph_shared.errors import ConfigError

#: sigma(z) / z^2 of a D435 at 640 x 480 (m^-1).
D400_SIGMA_PER_M2 = 0.0042


@dataclass(frozen=True)
class DepthNoise:
    """How far the rendered depth is from perfect. ``scale`` multiplies the D400's noise
    (0: exact depth, 2: "sensor noise doubled")."""

    scale: float = 1.0
    edge_dropout: float = 0.6
    #: A depth step larger than this inside one pixel is an edge (metres).
    edge_step: float = 0.01
    holes: int = 6
    min_range: float = 0.2
    max_range: float = 3.0

    def __post_init__(self) -> None:
        if not 0 <= self.scale <= 10:
            raise ConfigError("depth-noise", "must be in [0, 10] (times a RealSense D400's)")
        if not 0 <= self.edge_dropout <= 1:
            raise ConfigError("depth-noise.edge_dropout", "must be a probability in [0, 1]")
        if not 0 <= self.holes <= 100:
            raise ConfigError("depth-noise.holes", "must be in [0, 100] per frame")
        if not 0 <= self.min_range < self.max_range:
            raise ConfigError("depth-noise.range", "min_range must be below max_range")

    @classmethod
    def none(cls) -> DepthNoise:
        """Perfect depth (the renderer's, quantised to the sensor's 1 mm)."""
        return cls(scale=0.0, edge_dropout=0.0, holes=0)


def sensor_depth(
    fine: np.ndarray, factor: int, noise: DepthNoise, rng: np.random.Generator
) -> np.ndarray:
    """Depth in metres (0: none) at the published size, from ``fine``: the renderer's depth
    (metres along the optical axis, 0 where nothing was hit) at ``factor`` times that size."""
    h, w = fine.shape[0] // factor, fine.shape[1] // factor
    tiles = fine[: h * factor, : w * factor].reshape(h, factor, w, factor)
    blocks = tiles.transpose(0, 2, 1, 3).reshape(h, w, factor * factor)
    hit = blocks > 0
    near = np.where(hit, blocks, np.inf).min(axis=2)
    far = np.where(hit, blocks, 0.0).max(axis=2)
    count = hit.sum(axis=2)
    depth = np.where(count > 0, blocks.sum(axis=2) / np.maximum(count, 1), 0.0)
    # Mixed pixels at a step: the nearer surface, as a matcher locks on it when it matches.
    edge = (count > 0) & (far - near > noise.edge_step)
    depth = np.where(edge, near, depth)
    depth[count < factor * factor // 2] = 0.0
    # ... and pixels next to a step (a step may fall exactly between two pixels).
    kernel = np.ones((3, 3), np.uint8)
    grey = depth.astype(np.float32)
    edge |= (cv2.dilate(grey, kernel) - cv2.erode(grey, kernel)) > noise.edge_step
    if noise.scale > 0:
        sigma = noise.scale * D400_SIGMA_PER_M2 * depth**2
        depth = depth + rng.normal(0.0, 1.0, depth.shape) * sigma
    if noise.edge_dropout > 0:
        depth[edge & (rng.random(depth.shape) < noise.edge_dropout)] = 0.0
    if noise.holes:
        mask = np.zeros(depth.shape, np.uint8)
        for _ in range(noise.holes):
            centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
            axes = (int(rng.integers(3, 13)), int(rng.integers(3, 13)))
            angle = float(rng.uniform(0, 180))
            cv2.ellipse(mask, centre, axes, angle, 0, 360, 1, -1)
        depth[mask > 0] = 0.0
    depth[(depth < noise.min_range) | (depth > noise.max_range)] = 0.0
    return np.round(depth * 1000.0) / 1000.0


def encode_depth_png(depth: np.ndarray) -> bytes:
    """Metres -> the contract's 16-bit PNG of millimetres (0: none)."""
    millimetres = np.clip(np.round(depth * 1000.0), 0, 65535).astype(np.uint16)
    ok, data = cv2.imencode(".png", millimetres, [cv2.IMWRITE_PNG_COMPRESSION, 6])
    if not ok:
        raise ConfigError("camera.depth", "OpenCV cannot encode a 16-bit PNG")
    return bytes(data.tobytes())
