"""One object from its segment's points: centre, yaw from the top face, size, colour.

The points are in the levelled base frame (the table is z = 0). The **top face** is the
segment's points within ``top_band`` of its highest (95th percentile) height; seen from
above it is a rectangle: ``cv2.minAreaRect`` of its x, y gives the centre, the footprint and
the yaw (modulo the face's symmetry). The **height** is the top over the table. A face that
is not a rectangle (a thin strip or an L: the top edges of the sides of an object whose top
is under another one) makes a *covered* object: it is there, its centre only roughly known
(half its depth behind the side, away from the camera; the pipeline keeps its belief).

The **colour** is the palette name (``manigraph_shared.colours``) nearest in hue: of the
task's vocabulary when the layout names colours (and one is within ``VOCABULARY_REACH``),
else of the palette's chromatic colours.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from manigraph_perception.pipelines.rgbd.segment import hue_distance
from manigraph_shared.colours import PALETTE

#: Palette colours a hue can name (white, black and grey have none).
CHROMATIC = tuple(name for name, (r, g, b) in PALETTE.items() if max(r, g, b) - min(r, g, b) > 0.3)


@dataclass(frozen=True)
class ObjectConfig:
    top_band: float = 0.008
    #: A top face whose short side is less than this share of its long side is covered.
    square: float = 0.55
    #: ... or whose convex hull fills less than this share of its rectangle.
    filled: float = 0.7
    min_top_points: int = 20
    #: Lowest point under this (metres): it stands on the table (the segmentation cuts the
    #: first ~1 cm above it), so its height is its top's.
    on_table: float = 0.018
    #: Off the table, a segment less tall than this is no object.
    min_height: float = 0.01


@dataclass
class DetectedObject:
    centre: np.ndarray  # x, y, z of the top face's centre (metres, levelled base frame)
    yaw: float  # radians, in [-pi/4, pi/4) for a square top, else [-pi/2, pi/2)
    size: np.ndarray  # footprint x, y along the yaw, and height over its lowest point
    hue: float
    colour: str
    covered: bool
    pixels: int
    bottom: float  # lowest point's height
    #: Horizontal unit vector from the camera towards the object, and the top face's extent
    #: along it (its far edge meets the background at a depth step and loses pixels).
    away: np.ndarray
    extent_away: float

    @property
    def top(self) -> float:
        return float(self.centre[2])


def palette_hues(names: Iterable[str]) -> dict[str, float]:
    """OpenCV hue of each named palette colour."""
    hues = {}
    for name in names:
        if name not in PALETTE:
            continue
        r, g, b = PALETTE[name]
        bgr = np.array([[[round(b * 255), round(g * 255), round(r * 255)]]], np.uint8)
        hues[name] = float(cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)[0, 0, 0])
    return hues


def robust_rectangle(
    xy: np.ndarray, trim: float = 2.0
) -> tuple[tuple[float, float], tuple[float, float], float]:
    """Centre, sides and angle (radians) of the rectangle of least area holding all but the
    ``trim`` percent outermost points on each side (a few mixed or noisy edge pixels move
    ``cv2.minAreaRect`` by degrees): 1 degree steps over 90, then 0.1 degree round the best."""
    centred = xy - xy.mean(axis=0)

    def extents(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
        u = centred[:, 0] * c + centred[:, 1] * s
        v = -centred[:, 0] * s + centred[:, 1] * c
        low = np.percentile(np.stack([u, v]), trim, axis=2)
        high = np.percentile(np.stack([u, v]), 100 - trim, axis=2)
        return low, high

    coarse = np.deg2rad(np.arange(0.0, 90.0, 1.0))
    low, high = extents(coarse)
    best = coarse[int(np.argmin(np.prod(high - low, axis=0)))]
    fine = best + np.deg2rad(np.arange(-1.0, 1.01, 0.1))
    low, high = extents(fine)
    index = int(np.argmin(np.prod(high - low, axis=0)))
    angle = float(fine[index])
    (u0, v0), (u1, v1) = low[:, index], high[:, index]
    # The trimmed extent of a uniformly covered side is (1 - 2 trim%) of it.
    scale = 1.0 / (1.0 - 2 * trim / 100)
    mu, mv = (u0 + u1) / 2, (v0 + v1) / 2
    c, s = np.cos(angle), np.sin(angle)
    centre = xy.mean(axis=0) + np.array([mu * c - mv * s, mu * s + mv * c])
    return (float(centre[0]), float(centre[1])), ((u1 - u0) * scale, (v1 - v0) * scale), angle


#: A hue further than this (OpenCV units, 2 degrees each) from every colour of the task's
#: vocabulary is none of them: it is named from the whole palette instead.
VOCABULARY_REACH = 12.0


def colour_name(hue: float, vocabulary: dict[str, float]) -> str:
    """The vocabulary's colour nearest in hue, or the palette's if none is near."""
    name = min(vocabulary, key=lambda n: hue_distance(hue, vocabulary[n]))
    if hue_distance(hue, vocabulary[name]) <= VOCABULARY_REACH:
        return name
    palette = palette_hues(CHROMATIC)
    return min(palette, key=lambda n: hue_distance(hue, palette[n]))


def describe_object(
    points: np.ndarray,
    hue: float,
    vocabulary: dict[str, float],
    camera: np.ndarray,
    config: ObjectConfig,
) -> DetectedObject | None:
    """The object of one segment's points (N x 3), or None if it shows too little top."""
    z = points[:, 2]
    top = float(np.percentile(z, 95))
    face = points[z > top - config.top_band]
    if len(face) < config.min_top_points:
        return None
    flat = face[:, :2].astype(np.float32)
    (cx, cy), (w, h), yaw = robust_rectangle(face[:, :2])
    hull = float(cv2.contourArea(cv2.convexHull(flat)))
    bottom = float(np.percentile(z, 2))
    if top - bottom < config.min_height and bottom > config.on_table:
        return None  # a sliver in the air: the band of mixed hues between two objects
    if w < h:
        w, h, yaw = h, w, yaw + np.pi / 2
    # A strip, or an L (the top edges of two sides), fills little of its rectangle.
    covered = h < config.square * w or hull < config.filled * w * h
    centre = np.array([cx, cy, top])
    away = centre[:2] - camera[:2]
    away /= max(float(np.linalg.norm(away)), 1e-9)
    along = face[:, :2] @ away
    extent_away = float(np.percentile(along, 98) - np.percentile(along, 2)) / 0.96
    if covered:
        # A strip along the side's top edge: the centre is half the object's depth behind it.
        centre[:2] += away * w / 2
    period = np.pi / 2 if covered or h > 0.8 * w else np.pi  # a square top's yaw is mod 90
    yaw = (yaw + period / 2) % period - period / 2
    return DetectedObject(
        centre=centre,
        yaw=float(yaw),
        size=np.array([w, w if covered else h, top if bottom < config.on_table else top - bottom]),
        hue=hue,
        colour=colour_name(hue, vocabulary),
        covered=covered,
        pixels=len(points),
        bottom=bottom,
        away=away,
        extent_away=extent_away,
    )
