"""Motion blur: measured on the markers already found, undone before looking for the rest.

A camera that shakes or moves while it exposes smears the image along one direction; a 5-px
smear loses half of the small markers (their 2-3 px cells merge). The markers that are still
found say how long the smear is: each is a known pattern, so its sharp image is drawn at its
detected corners and smeared by each candidate length, along the image's rows and along its
columns; the smear that matches the image best (normalised correlation, median over the
markers) is the camera's. A smear of ``MIN_BLUR_PX`` or more is undone by Wiener
deconvolution along its axis, and the markers missed are looked for again in the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: Shorter smears cost few markers (3 px: 9 in 10 are found) and are left alone.
MIN_BLUR_PX = 3
MAX_BLUR_PX = 15
#: Signal-to-noise ratio of the Wiener filter (the image's noise is a few grey levels).
WIENER_SNR = 30.0
#: Markers measured per frame (the largest: their patterns are resolved best).
MEASURED_MARKERS = 4
#: (axis, length) smears compared: none, then every length along rows and along columns.
ALL_BLURS = [(1, 1)] + [(axis, n) for n in range(2, MAX_BLUR_PX + 1) for axis in (1, 0)]
SHORT_LIST = [(1, 1), (1, MIN_BLUR_PX), (0, MIN_BLUR_PX)]


@dataclass(frozen=True)
class Blur:
    """A box-shaped smear of ``length`` px along ``axis`` (1: rows, horizontal; 0: columns)."""

    axis: int
    length: int


class BlurGauge:
    """Measures the smear on detected markers of one ArUco dictionary."""

    def __init__(self, dictionary: cv2.aruco.Dictionary, cell_px: int = 8) -> None:
        self.dictionary = dictionary
        self.cell_px = cell_px
        self.patterns: dict[int, np.ndarray] = {}

    def pattern(self, marker_id: int) -> np.ndarray:
        """The marker's sharp image with a one-cell white margin (float, 0-1)."""
        if marker_id not in self.patterns:
            cells = self.dictionary.markerSize + 2
            inner = cv2.aruco.generateImageMarker(self.dictionary, marker_id, cells * self.cell_px)
            margin = self.cell_px
            self.patterns[marker_id] = np.asarray(
                cv2.copyMakeBorder(
                    inner, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255
                ),
                dtype=np.float32,
            )
        return self.patterns[marker_id]

    def measure(self, grey: np.ndarray, markers: list[tuple[int, np.ndarray]]) -> Blur | None:
        """The smear seen on ``markers`` (id, 4 x 2 corners), None if none is measurable."""
        largest = sorted(markers, key=lambda m: -cv2.contourArea(m[1].astype(np.float32)))
        # First sharp against the shortest smears worth undoing: a sharp frame (the usual
        # case) costs three comparisons per marker, not thirty.
        for candidates in (SHORT_LIST, None):
            scores: dict[tuple[int, int], list[float]] = {}
            for marker_id, corners in largest[:MEASURED_MARKERS]:
                for blur, score in self._scores(grey, marker_id, corners, candidates).items():
                    scores.setdefault(blur, []).append(score)
            if not scores:
                return None
            axis, length = max(scores, key=lambda b: float(np.median(scores[b])))
            if length == 1:
                return Blur(axis, length)
        return Blur(axis, length)

    def _scores(
        self,
        grey: np.ndarray,
        marker_id: int,
        corners: np.ndarray,
        candidates: list[tuple[int, int]] | None,
    ) -> dict[tuple[int, int], float]:
        pattern = self.pattern(marker_id)
        cells = self.dictionary.markerSize + 2
        side = cells * self.cell_px
        square = (
            np.array([[0, 0], [side, 0], [side, side], [0, side]], np.float32) + self.cell_px - 0.5
        )
        # The ROI round the marker and its margin, with room for the longest smear.
        centre = corners.mean(axis=0)
        with_margin = centre + (corners - centre) * (cells + 2) / cells
        x0, y0 = np.floor(with_margin.min(axis=0)).astype(int) - MAX_BLUR_PX
        x1, y1 = np.ceil(with_margin.max(axis=0)).astype(int) + MAX_BLUR_PX
        if x0 < 0 or y0 < 0 or x1 >= grey.shape[1] or y1 >= grey.shape[0]:
            return {}
        homography = cv2.getPerspectiveTransform(square, (corners - [x0, y0]).astype(np.float32))
        size = (x1 - x0, y1 - y0)
        drawn = cv2.warpPerspective(
            pattern, homography, size, flags=cv2.INTER_AREA, borderValue=255.0
        )
        mask = cv2.warpPerspective(
            np.ones_like(pattern), homography, size, flags=cv2.INTER_NEAREST
        ).astype(bool)
        if mask.sum() < 50:
            return {}
        image = grey[y0:y1, x0:x1].astype(np.float32)[mask]
        image = (image - image.mean()) / (image.std() + 1e-6)
        scores = {}
        for axis, length in candidates or ALL_BLURS:
            kernel = (length, 1) if axis == 1 else (1, length)
            smeared = cv2.blur(drawn, kernel)[mask]
            smeared = (smeared - smeared.mean()) / (smeared.std() + 1e-6)
            scores[(axis, length)] = float(np.mean(image * smeared))
        return scores


def wiener(grey: np.ndarray, blur: Blur, snr: float = WIENER_SNR) -> np.ndarray:
    """``grey`` with a box smear of ``blur`` undone (Wiener deconvolution along its axis)."""
    image = grey.astype(np.float32) if blur.axis == 1 else grey.astype(np.float32).T
    width = image.shape[1]
    kernel = np.zeros(width, np.float32)
    kernel[: blur.length] = 1.0 / blur.length
    kernel = np.roll(kernel, -(blur.length // 2))
    spectrum = np.fft.rfft(kernel)
    restored = np.fft.irfft(
        np.fft.rfft(image, axis=1) * np.conj(spectrum) / (np.abs(spectrum) ** 2 + 1.0 / snr),
        n=width,
        axis=1,
    )
    restored = restored if blur.axis == 1 else restored.T
    return np.clip(restored, 0, 255).astype(np.uint8)
