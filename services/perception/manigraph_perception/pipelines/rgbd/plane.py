"""The table plane in a depth frame: RANSAC over the back-projected points, in numpy.

Why not Open3D's ``segment_plane``: it is the same RANSAC, but the wheel is 100+ MB with its
own GUI stack, for ~30 lines here; numpy's vectorised version scores 48 hypotheses on 2000
points in ~2 ms, within the frame budget (bench/bench_rgbd.py).

The camera is calibrated, so the table is expected at z = 0 of the robot base frame: only
planes within ``max_tilt`` of horizontal and ``max_offset`` of z = 0 are considered (a box's
wall or the robot's base are not the table). The plane found is then used to correct what the
calibration gets wrong in roll, pitch and height (a camera knocked by a degree moves a point
0.75 m away by 13 mm; measured against the table it does not).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlaneConfig:
    iterations: int = 48
    sample: int = 2000
    #: A point within this of a plane is one of its inliers (metres; a D400's noise is
    #: ~3 mm at 0.8 m).
    inlier: float = 0.008
    #: The table's normal within this of the base frame's +z (degrees) ...
    max_tilt: float = 8.0
    #: ... and its height within this of z = 0 (metres).
    max_offset: float = 0.04
    #: Fewer inliers than this share of the valid points: no table in view.
    min_share: float = 0.2


@dataclass(frozen=True)
class Plane:
    """``normal . p + offset = 0`` in the base frame, ``normal`` a unit vector pointing up."""

    normal: np.ndarray
    offset: float
    share: float  # of the sampled points, the plane's inliers

    def heights(self, points: np.ndarray) -> np.ndarray:
        return points @ self.normal + self.offset

    def levelling(self) -> np.ndarray:
        """4 x 4: the base frame corrected so that this plane is z = 0 (turned about the
        point of the plane under the origin, shifted vertically)."""
        z = np.array([0.0, 0.0, 1.0])
        axis = np.cross(self.normal, z)
        sin, cos = float(np.linalg.norm(axis)), float(self.normal @ z)
        rotation = np.eye(3)
        if sin > 1e-9:
            k = axis / sin
            skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            rotation = np.eye(3) + sin * skew + (1 - cos) * skew @ skew
        out = np.eye(4)
        out[:3, :3] = rotation
        out[2, 3] = self.offset / cos  # the plane's point (0, 0, -offset/cos) goes to z = 0
        return out


class NoTablePlane(ValueError):
    """No plane near the calibrated table holds enough of the frame's points."""


def fit_table(
    sample: np.ndarray,
    config: PlaneConfig,
    rng: np.random.Generator,
    previous: Plane | None = None,
) -> Plane:
    """The table plane of ``sample`` (N x 3 points, base frame, drawn from the frame's
    pixels with depth); ``previous`` is tried as one more
    hypothesis (the table does not move between frames). ``NoTablePlane`` says why not."""
    if len(sample) < 100:
        raise NoTablePlane(f"only {len(sample)} points with depth")
    triples = sample[rng.integers(0, len(sample), (config.iterations, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    good = lengths > 1e-9
    normals = normals[good] / lengths[good, None]
    normals *= np.sign(normals[:, 2:3] + 1e-12)
    offsets = -np.einsum("ij,ij->i", normals, triples[good, 0])
    if previous is not None:
        normals = np.vstack([normals, previous.normal])
        offsets = np.append(offsets, previous.offset)
    plausible = (normals[:, 2] >= np.cos(np.deg2rad(config.max_tilt))) & (
        np.abs(offsets) <= config.max_offset
    )
    if not plausible.any():
        raise NoTablePlane(
            f"no plane within {config.max_tilt:g} deg and {config.max_offset * 100:g} cm "
            "of the calibrated table"
        )
    normals, offsets = normals[plausible], offsets[plausible]
    distances = np.abs(sample @ normals.T + offsets)
    counts = (distances < config.inlier).sum(axis=0)
    best = int(np.argmax(counts))
    share = float(counts[best]) / len(sample)
    if share < config.min_share:
        raise NoTablePlane(
            f"the best table plane holds {share:.0%} of the points (at least "
            f"{config.min_share:.0%} needed)"
        )
    inliers = sample[distances[:, best] < config.inlier]
    centre = inliers.mean(axis=0)
    normal = np.linalg.svd(inliers - centre, full_matrices=False)[2][2]
    normal *= np.sign(normal[2])
    return Plane(normal, float(-normal @ centre), share)
