"""An RGB-D frame: a colour image and the depth image of the same sequence, decoded."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from manigraph_perception.image_guard import depth_problem, opencv_reason, size_problem
from manigraph_perception.pipeline import BadFrame
from manigraph_shared.messages import CompressedImage, DepthImage


@dataclass
class RgbdFrame:
    bgr: np.ndarray  # H x W x 3 uint8
    depth: np.ndarray  # H x W metres, 0: none
    stamp: float
    sequence: int


def decode_pair(image: CompressedImage, depth: DepthImage, width: int, height: int) -> RgbdFrame:
    """Colour and depth messages of a ``width`` x ``height`` camera -> a frame; ``BadFrame``
    naming why not. The size is checked from each header before anything is decoded."""
    problem = depth_problem(depth.data, width, height) or size_problem(
        "colour image", image.data, width, height
    )
    if problem is not None:
        raise BadFrame(problem.kind, f"frame {image.sequence}: {problem.reason}")
    try:
        bgr = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_COLOR)
        metres = decode_depth(depth.data)
    except cv2.error as exc:
        raise BadFrame(
            "unreadable", f"frame {image.sequence}: {opencv_reason(exc, 'decoding it')}"
        ) from None
    if bgr is None or metres is None:
        raise BadFrame("unreadable", f"frame {image.sequence} does not decode")
    return RgbdFrame(bgr, metres, image.stamp, image.sequence)


def decode_depth(data: bytes) -> np.ndarray | None:
    """The contract's 16-bit PNG of millimetres -> metres (0: none); None if it is not one."""
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.dtype != np.uint16 or image.ndim != 2:
        return None
    return image.astype(np.float64) / 1000.0
