"""Where RGB-D frames come from when not from the bus: an Intel RealSense (``pyrealsense2``,
imported only when asked for) or a recorded MCAP file of ``CompressedImage`` + ``DepthImage``
(a user's own recording replayed through the pipeline). Both give ``RgbdFrame``s and say
when the camera has stopped with a ``ConfigError``, as ArUco's ``VideoSource`` does.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from manigraph_perception.pairing import HalfBuffer
from manigraph_perception.pipeline import MAX_FAILED_READS, BadFrame, FrameSource
from manigraph_perception.pipelines.rgbd.frames import RgbdFrame, decode_pair
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import CameraInfo, CompressedImage, DepthImage


class McapRgbdSource:
    """Recorded frames: each ``CompressedImage`` of ``camera`` paired with the ``DepthImage``
    of the same sequence, in the file's order (at ``rate`` frames per second, 0: at once).
    The recording's ``CameraInfo`` is in ``info`` (None if it has none). Frames are checked
    against ``size`` (width, height; by default the recording's ``CameraInfo``) before they
    are decoded; one that does not fit raises ``BadFrame``."""

    def __init__(
        self,
        path: str | Path,
        camera: str = "front",
        rate: float = 0.0,
        size: tuple[int, int] | None = None,
    ) -> None:
        from manigraph_shared.mcap_log import read_log

        self.path = Path(path)
        if not self.path.is_file():
            raise ConfigError("camera", f"no such recording: {self.path}")
        keys = [f"manigraph/camera/{camera}/{k}" for k in ("image", "depth", "info")]
        self._messages = (m.decode() for m in read_log(self.path, keys))
        self.rate = rate
        self.size = size
        self.info: CameraInfo | None = None
        # Read at once, not waited for: no age bound, only the count.
        self._depths: HalfBuffer[DepthImage] = HalfBuffer(max_age=None)
        self._images: HalfBuffer[CompressedImage] = HalfBuffer(max_age=None)
        self._ended = False
        self._next = 0.0
        self.frames = 0
        self._pairing = self._pairs()

    def read(self) -> RgbdFrame | None:
        if self.rate > 0:
            time.sleep(max(0.0, self._next - time.monotonic()))
            self._next = time.monotonic() + 1 / self.rate
        pair = next(self._pairing, None)
        if pair is not None:
            self.frames += 1
            size = self.size
            if size is None and self.info is not None:
                size = (self.info.width, self.info.height)
            if size is None:
                raise BadFrame(
                    "unreadable",
                    f"frame {pair[0].sequence}: no size to check it against (no CameraInfo "
                    "before it in the recording, no calibration)",
                )
            return decode_pair(*pair, *size)
        raise ConfigError(
            "camera", f"recording {self.path.name} ended after {self.frames} RGB-D frames"
        )

    def _pairs(self) -> Iterator[tuple[CompressedImage, DepthImage]]:
        for message in self._messages:
            if isinstance(message, CameraInfo):
                self.info = message
                continue
            if not isinstance(message, (DepthImage, CompressedImage)):
                continue
            sequence = message.sequence
            if isinstance(message, DepthImage):
                image = self._images.pop(sequence)
                if image is None:
                    self._depths.hold(sequence, message)
                    continue
                depth = message
            elif isinstance(message, CompressedImage):
                found = self._depths.pop(sequence)
                if found is None:
                    self._images.hold(sequence, message)
                    continue
                image, depth = message, found
            else:
                continue
            # Older halves whose partner never came are let go.
            self._images.drop_older(sequence)
            self._depths.drop_older(sequence)
            yield image, depth

    def close(self) -> None:
        self._messages.close()


class RealSenseSource:
    """An Intel RealSense D400 through ``pyrealsense2``: colour and depth at ``width`` x
    ``height``, depth aligned to colour, in metres. ``ConfigError`` at start without the
    package or the device, and once it stops delivering."""

    def __init__(self, width: int = 640, height: int = 480, fps: int = 30) -> None:
        try:
            import pyrealsense2 as rs
        except ImportError:
            raise ConfigError(
                "camera",
                "realsense needs the pyrealsense2 package (pip install pyrealsense2; not a "
                "dependency of manigraph) and a connected RealSense",
            ) from None
        self.rs: Any = rs
        if not rs.context().query_devices():
            raise ConfigError("camera", "realsense: no RealSense device connected")
        self.pipeline = rs.pipeline()
        config = rs.config()
        config.enable_stream(rs.stream.color, width, height, rs.format.bgr8, fps)
        config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
        try:
            profile = self.pipeline.start(config)
        except RuntimeError as exc:
            raise ConfigError("camera", f"realsense: cannot start streaming: {exc}") from None
        self.depth_scale = profile.get_device().first_depth_sensor().get_depth_scale()
        self.align = rs.align(rs.stream.color)
        intrinsics = profile.get_stream(rs.stream.color).as_video_stream_profile()
        self.intrinsics = intrinsics.get_intrinsics()
        self.failed_in_a_row = 0
        self.sequence = 0

    def camera_matrix(self) -> np.ndarray:
        i = self.intrinsics
        return np.array([[i.fx, 0, i.ppx], [0, i.fy, i.ppy], [0, 0, 1]], dtype=float)

    def read(self) -> RgbdFrame | None:
        try:
            frames = self.align.process(self.pipeline.wait_for_frames(1000))
        except RuntimeError:
            frames = None
        colour = frames.get_color_frame() if frames else None
        depth = frames.get_depth_frame() if frames else None
        if not colour or not depth:
            self.failed_in_a_row += 1
            if self.failed_in_a_row >= MAX_FAILED_READS:
                raise ConfigError("camera", "realsense stopped delivering frames")
            return None
        self.failed_in_a_row = 0
        self.sequence += 1
        metres = np.asanyarray(depth.get_data()).astype(np.float64) * self.depth_scale
        bgr = np.asanyarray(colour.get_data()).copy()
        return RgbdFrame(bgr, metres, time.time(), self.sequence)

    def close(self) -> None:
        self.pipeline.stop()


def open_rgbd_source(
    spec: str, camera: str = "front", size: tuple[int, int] | None = None
) -> FrameSource[RgbdFrame]:
    """``realsense`` or an ``.mcap`` recording (``ConfigError`` for anything else); ``size``:
    the calibrated (width, height) a recording's frames are checked against."""
    if spec == "realsense":
        return RealSenseSource()
    if spec.endswith(".mcap"):
        return McapRgbdSource(spec, camera, size=size)
    raise ConfigError(
        "camera", f"'{spec}' is not an RGB-D source: 'bus', 'realsense' or a .mcap recording"
    )
