"""A picture of what the RGB-D pipeline saw in a frame: every segment outlined in the
colour it was named, its object id (or ``?`` if it matched none), and the depth beside.

    python -m manigraph_perception.pipelines.rgbd.drawing RECORDING.mcap --calibration CAL.yaml \\
        --frame 12 -o segmentation.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from manigraph_perception.pipelines.rgbd.pipeline import RgbdFrameResult
from manigraph_shared.colours import PALETTE


def draw_segmentation(bgr: np.ndarray, depth: np.ndarray, result: RgbdFrameResult) -> np.ndarray:
    """The colour image with the segments outlined and labelled, beside the depth (near:
    bright; no depth: black)."""
    out = (bgr * 0.55).astype(np.uint8)
    ids = {id(d): object_id for object_id, d in result.matches.items()}
    for index, detection in enumerate(result.detections):
        mask = (result.labels == index + 1).astype(np.uint8)
        r, g, b = PALETTE[detection.colour]
        colour = (round(b * 255), round(g * 255), round(r * 255))
        out[mask > 0] = (0.4 * out[mask > 0] + 0.6 * np.array(colour)).astype(np.uint8)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, (255, 255, 255), 1, cv2.LINE_AA)
        label = ids.get(id(detection), "?").replace("block_", "b")
        if detection.covered:
            label += "*"
        x, y, w, h = cv2.boundingRect(mask)
        at = (x + w + 3, y + h // 2 + 4)
        font = cv2.FONT_HERSHEY_SIMPLEX
        cv2.putText(out, label, at, font, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
    valid = depth > 0
    shade = np.zeros(depth.shape, np.uint8)
    if valid.any():
        near, far = np.percentile(depth[valid], [1, 99])
        scaled = 255 * (far - depth) / max(far - near, 1e-6)
        shade[valid] = np.clip(scaled[valid], 30, 255).astype(np.uint8)
    return np.hstack([out, cv2.applyColorMap(shade, cv2.COLORMAP_BONE)])


def main(argv: list[str] | None = None) -> int:
    from manigraph_perception.calibration_file import load_calibration
    from manigraph_perception.pipelines.rgbd.pipeline import BadFrame, RgbdPerception
    from manigraph_perception.pipelines.rgbd.sources import McapRgbdSource
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.mcap_log import read_log
    from manigraph_shared.messages import TaskLayout

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording")
    parser.add_argument("--calibration", required=True)
    parser.add_argument("--frame", type=int, default=0, help="which RGB-D frame (0: first)")
    parser.add_argument("-o", "--output", required=True)
    args = parser.parse_args(argv)
    calibration = load_calibration(args.calibration)
    perception = RgbdPerception(calibration)
    layouts = [m.decode() for m in read_log(Path(args.recording), ["manigraph/world/layout"])]
    source = McapRgbdSource(args.recording, size=(calibration.width, calibration.height))
    result: RgbdFrameResult | BadFrame | None = None
    frame = None
    try:
        # Every frame up to the one drawn goes through the pipeline: identity is tracked.
        for _ in range(args.frame + 1):
            try:
                frame = source.read()
            except BadFrame as exc:
                frame, result = None, exc
            if frame is None:
                continue
            earlier = [x for x in layouts if isinstance(x, TaskLayout) and x.stamp <= frame.stamp]
            if earlier:
                perception.set_layout(earlier[-1])
            try:
                result = perception.process(frame.bgr, frame.depth, frame.stamp, frame.stamp)[1]
            except BadFrame as exc:
                result = exc
    except ConfigError as exc:
        print(f"drawing: {exc}", file=sys.stderr)
        return 2
    if not isinstance(result, RgbdFrameResult) or frame is None:
        print(f"drawing: frame {args.frame}: {result or 'does not decode'}", file=sys.stderr)
        return 1
    cv2.imwrite(
        args.output,
        draw_segmentation(frame.bgr, frame.depth, result),
        [cv2.IMWRITE_PNG_COMPRESSION, 9],
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
