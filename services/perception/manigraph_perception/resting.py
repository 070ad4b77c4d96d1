"""A resting block's depth from what it rests on.

A marker pose is good across the image (~1 mm) and poor along the viewing ray: a 15-px marker
whose corners move by a fraction of a pixel (noise, motion blur) moves the pose by centimetres
along the ray, and nowhere else. A block at rest, though, rests on something: the table
(z = 0), a box's floor, or the top of another object. Each such support is a horizontal plane,
and the ray from the camera through the measured centre meets the plane where the block's
centre must be. Of the supports whose point is near the measured one (along the ray), that
exist there (a block under it, a box round it) and leave the block clear of its neighbours, the
nearest is taken; a block with none (held in the air) keeps its measured pose. A block seen
on the ray through where it is believed to be has not moved (``same_place``): a centimetre of
noise along the ray does not take it off the block under it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Support:
    """A horizontal surface at height ``z``: everywhere (``half_extent`` None: the table) or
    over the rectangle of ``half_extent`` (x, y) round ``centre`` (x, y)."""

    z: float
    centre: tuple[float, float] = (0.0, 0.0)
    half_extent: tuple[float, float] | None = None

    def holds(self, point: np.ndarray) -> bool:
        if self.half_extent is None:
            return True
        return bool(
            abs(point[0] - self.centre[0]) <= self.half_extent[0]
            and abs(point[1] - self.centre[1]) <= self.half_extent[1]
        )


@dataclass(frozen=True)
class RestConfig:
    #: Metres along the viewing ray: a support this far from the measured centre is not it.
    max_shift: float = 0.045
    #: A block overlapping another this much (metres, centre to centre) is not there.
    clearance: float = 0.03
    #: A block whose viewing ray passes this close (metres) to where it is believed to be is
    #: still there: the ray is what the image measures well.
    same_place: float = 0.008


def rest_on_support(
    measured: np.ndarray,
    camera: np.ndarray,
    half_height: float,
    supports: list[Support],
    neighbours: list[np.ndarray],
    config: RestConfig,
    excluded: list[Support] | None = None,
) -> np.ndarray | None:
    """The centre on the ray camera -> ``measured`` resting on the nearest valid support, or
    None when no support fits. ``excluded`` areas (a box's footprint) hold nothing from the
    table."""
    ray = measured - camera
    best: tuple[float, np.ndarray] | None = None
    for support in supports:
        z = support.z + half_height
        if abs(ray[2]) < 1e-6:
            continue
        t = (z - camera[2]) / ray[2]
        if t <= 0:
            continue
        point = camera + t * ray
        shift = float(np.linalg.norm(point - measured))
        if shift > config.max_shift or not support.holds(point):
            continue
        if support.half_extent is None and any(area.holds(point) for area in excluded or []):
            continue
        if any(
            np.linalg.norm(point[:2] - other[:2]) < config.clearance
            and abs(point[2] - other[2]) < config.clearance
            for other in neighbours
        ):
            continue
        if best is None or shift < best[0]:
            best = (shift, point)
    return None if best is None else best[1]
