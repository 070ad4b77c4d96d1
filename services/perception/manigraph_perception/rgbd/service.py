"""The perception service with the RGB-D pipeline: colour + depth frames from the bus (the
sim's ``--camera --camera-depth``, a camera driver) or from a source (a RealSense, an MCAP
recording) in, ``Scene`` out.

Bus frames are paired by ``sequence`` (in either order: the sim publishes a frame's depth
first, a driver may not) and handled newest-first, as the ArUco service does. A frame that
cannot be used is named in the service's status (``no table plane: ...``, ``depth 320 x 240
..., calibrated for ...``, ``no usable frame for 4 s``), with the age of the last good
Scene; that Scene is published again, ``stale``, with its own stamp: the planner decides
only on a Scene observed after its last skill ended, so it never acts on the old world.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import msgspec

from manigraph_perception.rgbd.pipeline import BadFrame, RgbdPerception
from manigraph_perception.rgbd.sources import RgbdFrame, RgbdSource, decode_pair
from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    DepthImage,
    JointState,
    Scene,
    ServiceState,
    TaskLayout,
)
from manigraph_shared.service import Service

_NO_FRAME = "no usable frame"


def _hold(held: dict[int, Any], sequence: int, message: Any) -> None:
    held[sequence] = message
    for old in [s for s in held if s < sequence - 4]:
        del held[old]


class RgbdPerceptionService(Service):
    name = "perception"

    def __init__(
        self,
        bus: Bus,
        perception: RgbdPerception,
        source: RgbdSource | None = None,
        layout: TaskLayout | None = None,
        poll_period: float = 1 / 30,
    ) -> None:
        super().__init__(bus)
        self.perception = perception
        self.source = source
        self.fixed_layout = layout
        self.tick_period = poll_period if source is not None else 0.5
        self._lock = threading.Lock()
        #: Halves of frames waiting for their other half, by sequence (a few at most).
        self._depths: dict[int, DepthImage] = {}
        self._images: dict[int, CompressedImage] = {}
        self._waiting: tuple[CompressedImage, DepthImage] | None = None
        self.last_good: Scene | None = None
        self.failed = False
        self.last_frame = 0.0
        self._problem = ""  # the last bad frame's reason, logged once per change

    def setup(self) -> None:
        if self.fixed_layout is not None:
            self.perception.set_layout(self.fixed_layout)
        else:
            self.on(TaskLayout, self.perception.set_layout)
        self.on(Action, self._on_action)
        self.on(JointState, lambda state: self.perception.world.on_gripper(state.gripper_width))
        if self.source is None:
            camera = self.perception.camera
            self.bus.subscribe(
                DepthImage,
                self._depth_arrived,
                on_error=self._rejected,
                key=f"manigraph/camera/{camera}/depth",
            )
            self.bus.subscribe(
                CompressedImage,
                self._image_arrived,
                on_error=self._rejected,
                key=f"manigraph/camera/{camera}/image",
            )
            self.on(CameraInfo, self._on_info, key=f"manigraph/camera/{camera}/info")

    def teardown(self) -> None:
        if self.source is not None:
            self.source.close()

    # --- inputs -----------------------------------------------------------------------------
    def _on_action(self, action: Action) -> None:
        self.perception.world.on_action(action.episode_id, action.object_id, action.goal_id)

    def _on_info(self, info: CameraInfo) -> None:
        calibration = self.perception.calibration
        if (info.width, info.height) != (calibration.width, calibration.height):
            raise ConfigError(
                "calibration",
                f"is for {calibration.width} x {calibration.height} images, "
                f"camera '{info.camera}' sends {info.width} x {info.height}",
            )

    def _depth_arrived(self, depth: DepthImage) -> None:
        with self._lock:  # Zenoh thread
            image = self._images.pop(depth.sequence, None)
            if image is None:
                _hold(self._depths, depth.sequence, depth)
                return
        self._pair(image, depth)

    def _image_arrived(self, image: CompressedImage) -> None:
        with self._lock:  # Zenoh thread
            depth = self._depths.pop(image.sequence, None)
            if depth is None:
                _hold(self._images, image.sequence, image)  # its depth may come next
                return
        self._pair(image, depth)

    def _pair(self, image: CompressedImage, depth: DepthImage) -> None:
        """A whole frame: keep only the newest waiting; schedule one processing."""
        with self._lock:
            waiting = self._waiting is not None
            self._waiting = (image, depth)
        if not waiting:
            self.call_soon(self._process_waiting)

    def _process_waiting(self, _: object = None) -> None:
        with self._lock:
            pair, self._waiting = self._waiting, None
        if pair is None:
            return
        layout = self.perception.layout
        if layout is not None and pair[0].stamp < layout.stamp:
            return  # taken before this episode was laid out
        frame = decode_pair(*pair)
        if frame is None:
            self._bad(BadFrame("wrong_size", f"frame {pair[0].sequence} does not decode"))
            return
        self._process(frame)

    # --- frames -----------------------------------------------------------------------------
    def _process(self, frame: RgbdFrame) -> None:
        now = time.time()
        self.last_frame = now
        try:
            scene, _ = self.perception.process(frame.bgr, frame.depth, frame.stamp, now)
        except BadFrame as exc:
            self._bad(exc)
            return
        if scene is None:
            return
        if not scene.stale:
            self.last_good = scene
            self._problem = ""
            self.last_error = ""
        self.bus.publish(scene)

    def _bad(self, problem: BadFrame) -> None:
        """Name the problem in the status; serve the last good Scene again, stale, with its
        own (old) stamp."""
        age = ""
        if self.last_good is not None:
            age = f"; last good scene {time.time() - self.last_good.stamp:.1f} s old"
            self.bus.publish(msgspec.structs.replace(self.last_good, stale=True))
        if str(problem) != self._problem:
            self.log.warning("frame skipped: %s", problem)
        self._problem = str(problem)
        self.last_error = f"{problem}{age}"

    # --- periodic ---------------------------------------------------------------------------
    def tick(self) -> None:
        now = time.time()
        if self.source is not None:
            try:
                frame = self.source.read()
            except ConfigError as exc:
                self.report_error(exc)
                self.failed = True
                self.stop_event.set()
                return
            if frame is not None:
                self._process(frame)
            return
        stale_after = self.perception.world.config.stale_after
        if self.perception.layout is not None and now - self.last_frame > stale_after:
            waited = f"for {now - self.last_frame:.0f} s" if self.last_frame else "yet"
            age = ""
            if self.last_good is not None:
                age = f"; last good scene {now - self.last_good.stamp:.1f} s old"
            self.last_error = f"{_NO_FRAME} {waited}{age}"

    def publish_status(self, state: ServiceState, detail: str = "") -> None:
        summary = self.perception.counters.summary()
        super().publish_status(state, f"{detail}; {summary}" if detail else summary)
