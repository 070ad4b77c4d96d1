"""Motion blur measured on the markers found, undone to find the rest (deblur.py)."""

from __future__ import annotations

import cv2
import numpy as np

from manigraph_perception.deblur import Blur, BlurGauge, wiener
from manigraph_perception.detection import detect, detector_for


def _smear(grey: np.ndarray, length: int, axis: int = 1) -> np.ndarray:
    """The sim camera's motion blur (a box along one axis) and 5 grey levels of noise."""
    kernel = (length, 1) if axis == 1 else (1, length)
    smeared = cv2.blur(grey, kernel).astype(np.float32)
    noisy = smeared + np.random.default_rng(0).normal(0, 5, grey.shape)
    return np.clip(noisy, 0, 255).astype(np.uint8)


def _measure(grey: np.ndarray, markers) -> Blur | None:  # type: ignore[no-untyped-def]
    found = detect(detector_for(markers)._replace(gauge=None), grey)
    gauge = BlurGauge(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250))
    return gauge.measure(grey, [(m.id, m.corners) for m in found])


def test_a_sharp_frame_measures_no_blur(frame, markers) -> None:  # type: ignore[no-untyped-def]
    assert _measure(frame("stack4-start").grey, markers) == Blur(1, 1)


def test_the_length_and_axis_of_a_smear_are_measured(frame, markers) -> None:  # type: ignore[no-untyped-def]
    grey = frame("boxpack3-start").grey
    assert _measure(_smear(grey, 5), markers) == Blur(1, 5)
    assert _measure(_smear(grey, 5, axis=0), markers) == Blur(0, 5)
    assert _measure(_smear(grey, 7), markers) == Blur(1, 7)


def test_undoing_the_blur_finds_the_markers_it_hid(frame, markers) -> None:  # type: ignore[no-untyped-def]
    grey = frame("stack4-one-placed").grey
    sharp = {m.id for m in detect(detector_for(markers), grey)}
    blurred = _smear(grey, 5)
    without = {m.id for m in detect(detector_for(markers)._replace(gauge=None), blurred)}
    with_gauge = {m.id for m in detect(detector_for(markers), blurred)}
    assert len(without) < 0.8 * len(sharp), (without, sharp)
    assert without < with_gauge <= sharp, (without, with_gauge, sharp)


def test_wiener_restores_a_smeared_edge() -> None:
    bar = np.zeros((40, 80), np.uint8)
    bar[:, 20:60] = 200
    smeared = cv2.blur(bar, (5, 1))
    assert np.abs(smeared.astype(int) - bar).max() > 70
    assert np.abs(wiener(smeared, Blur(1, 5), snr=1000.0).astype(int) - bar).max() < 15
