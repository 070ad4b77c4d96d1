"""Where ArUco frames come from when not from the bus: a V4L2 device, a video file or a stream
URL, all through ``cv2.VideoCapture`` (the hardware boundary)."""

from __future__ import annotations

import time

import cv2

from manigraph_perception.pipeline import MAX_FAILED_READS, BadFrame
from manigraph_perception.pipelines.aruco.pipeline import GreyFrame
from manigraph_shared.errors import ConfigError


class VideoSource:
    """Frames from ``cv2.VideoCapture``: ``/dev/video0`` or ``0``, a file, an RTSP/HTTP URL."""

    def __init__(self, spec: str) -> None:
        self.spec = spec
        device: int | str = int(spec) if spec.isdigit() else spec
        self.capture = cv2.VideoCapture(device)
        if not self.capture.isOpened():
            raise ConfigError(
                "camera", f"cannot open '{spec}' (no such device, file or stream, or no access)"
            )
        self.failed_in_a_row = 0
        self.sequence = 0

    def read(self) -> GreyFrame:
        """The next frame as grey, stamped as read; ``BadFrame`` for a dropped or corrupt
        one, ``ConfigError`` once the camera has stopped delivering."""
        ok, frame = self.capture.read()
        if not ok or frame is None or frame.size == 0:
            self.failed_in_a_row += 1
            if self.failed_in_a_row >= MAX_FAILED_READS:
                raise ConfigError("camera", f"'{self.spec}' stopped delivering frames")
            raise BadFrame("corrupt", f"'{self.spec}' gave no frame")
        self.failed_in_a_row = 0
        self.sequence += 1
        grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        return GreyFrame(grey, time.time(), self.sequence)

    def close(self) -> None:
        self.capture.release()
