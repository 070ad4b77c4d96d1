"""What stands on the table, cut into objects.

1. **Above the table**: pixels whose point is between ``min_height`` and ``max_height`` over
   the fitted plane, coloured (HSV saturation at least ``min_saturation``: the white and grey
   robot is not an object; the objects of the tasks here are coloured), not on a depth step.
2. **Connected in the image and in depth**: ``cv2.connectedComponentsWithStats`` on that
   mask. Pixels across a depth step of more than ``depth_step`` are cut first, so an object
   in front of another is apart from it even when their images touch. For a camera looking
   down on a table this is 3D clustering at the price of a 2D labelling (a height map above
   the plane seen from the camera).
3. **Split by colour**: a stack's blocks touch along a continuous depth surface (their
   visible sides); the component's hue histogram has one peak per colour, and each pixel goes
   to its nearest peak. Touching objects of one colour stay together here; ``objects.py``
   tells them apart by height.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: OpenCV's hue runs 0-179 for 0-358 degrees.
HUE_RANGE = 180


@dataclass(frozen=True)
class SegmentConfig:
    min_height: float = 0.008
    max_height: float = 0.45
    min_saturation: int = 60
    min_value: int = 35
    depth_step: float = 0.012
    #: A segment smaller than this is noise (a 4 cm block 0.9 m away shows ~400 px).
    min_pixels: int = 60
    #: Hue peaks nearer than this (OpenCV hue units, 2 degrees each) are one colour.
    hue_separation: int = 7
    #: A hue peak with less than this share of a component's pixels (or fewer than
    #: ``min_pixels``) is not an object (the bottom block of a stack of 6 shows ~7%).
    min_hue_share: float = 0.02


@dataclass
class Segment:
    """One object's pixels (row, column indices into the frame) and its hue."""

    rows: np.ndarray
    cols: np.ndarray
    hue: float  # OpenCV units, 0-179


def above_table(
    heights: np.ndarray, depth: np.ndarray, hsv: np.ndarray, config: SegmentConfig
) -> np.ndarray:
    """The mask of step 1 (``heights``: metres over the plane, NaN without depth; ``depth``:
    float32 metres, 0 without)."""
    with np.errstate(invalid="ignore"):
        mask = (heights > config.min_height) & (heights < config.max_height)
    mask &= (hsv[..., 1] >= config.min_saturation) & (hsv[..., 2] >= config.min_value)
    # A depth step within a pixel's 3 x 3 neighbourhood (holes count as steps).
    kernel = np.ones((3, 3), np.uint8)
    step = (cv2.dilate(depth, kernel) - cv2.erode(depth, kernel)) > config.depth_step
    return mask & ~step


def segments(mask: np.ndarray, hue: np.ndarray, config: SegmentConfig) -> list[Segment]:
    """Steps 2 and 3 on the mask of step 1."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8
    )
    out: list[Segment] = []
    for label in range(1, count):
        if stats[label, cv2.CC_STAT_AREA] < config.min_pixels:
            continue
        x, y, w, h = (stats[label, k] for k in range(4))
        window = labels[y : y + h, x : x + w] == label
        hues = hue[y : y + h, x : x + w]
        peaks = hue_peaks(hues[window], config)
        if len(peaks) == 1:
            rows, cols = np.nonzero(window)
            out.append(Segment(rows + y, cols + x, float(peaks[0])))
            continue
        nearest = np.argmin(
            [_hue_distance(hues.astype(np.float64), p) for p in peaks], axis=0
        ).astype(np.uint8)
        for index, peak in enumerate(peaks):
            part = (window & (nearest == index)).astype(np.uint8)
            n, part_labels, part_stats, _ = cv2.connectedComponentsWithStats(part, connectivity=8)
            for sub in range(1, n):
                if part_stats[sub, cv2.CC_STAT_AREA] >= config.min_pixels:
                    rows, cols = np.nonzero(part_labels == sub)
                    out.append(Segment(rows + y, cols + x, float(peak)))
    return out


def hue_peaks(hues: np.ndarray, config: SegmentConfig) -> list[float]:
    """The distinct hues of a set of pixels: peaks of its smoothed circular histogram with
    at least ``min_hue_share`` of the pixels (and ``min_pixels``) within ``hue_separation``."""
    histogram = np.bincount(hues.astype(np.int64) % HUE_RANGE, minlength=HUE_RANGE)
    kernel = np.ones(5) / 5
    smooth = np.convolve(np.concatenate([histogram[-2:], histogram, histogram[:2]]), kernel)
    smooth = smooth[4 : 4 + HUE_RANGE]
    total = max(len(hues), 1)
    peaks: list[float] = []
    for index in np.argsort(-smooth):
        if smooth[index] <= 0:
            break
        if any(_hue_distance(np.array([index]), p)[0] < config.hue_separation for p in peaks):
            continue
        near = _hue_distance(np.arange(HUE_RANGE), float(index)) < config.hue_separation
        count = histogram[near].sum()
        if count < config.min_pixels or count / total < config.min_hue_share:
            continue
        # The peak's hue: the mean of the pixels round it (the smoothing flattens its top).
        bins = np.arange(HUE_RANGE)[near]
        offsets = (bins - index + HUE_RANGE / 2) % HUE_RANGE - HUE_RANGE / 2
        peak = (index + float(offsets @ histogram[near]) / count) % HUE_RANGE
        if any(_hue_distance(np.array([peak]), p)[0] < config.hue_separation for p in peaks):
            continue
        peaks.append(float(peak))
    return peaks or [float(np.argmax(smooth))]


def _hue_distance(hues: np.ndarray, hue: float) -> np.ndarray:
    difference = np.abs(hues - hue) % HUE_RANGE
    return np.minimum(difference, HUE_RANGE - difference)


def hue_distance(a: float, b: float) -> float:
    """Circular distance of two OpenCV hues."""
    return float(_hue_distance(np.array([a]), b)[0])
