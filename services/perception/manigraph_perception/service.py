"""The perception service: frames from a camera or the bus in, ``Scene`` and detected
markers out. The work is :class:`~manigraph_perception.pipeline.Perception`'s; this wires it.

Bus images are handled newest-first: a frame that arrives while one is being processed
replaces the waiting one instead of queueing behind it (bounded work per frame, HOUSE_STYLE
point 12).
"""

from __future__ import annotations

import threading
import time

import cv2

from manigraph_perception.image_guard import opencv_reason
from manigraph_perception.pipeline import Perception
from manigraph_perception.sources import VideoSource
from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError, ManigraphError
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    JointState,
    MarkerDetections,
    Scene,
    ServiceState,
    TaskLayout,
)
from manigraph_shared.service import Service

_NO_FRAME = "no usable frame"


class PerceptionService(Service):
    name = "perception"

    def __init__(
        self,
        bus: Bus,
        perception: Perception,
        source: VideoSource | None = None,
        layout: TaskLayout | None = None,
        poll_period: float = 1 / 30,
    ) -> None:
        super().__init__(bus)
        self.perception = perception
        self.source = source
        self.fixed_layout = layout
        self.tick_period = poll_period if source is not None else 0.5
        self._latest: CompressedImage | None = None
        self._lock = threading.Lock()
        self.failed = False
        self._last_stale_report = 0.0

    def setup(self) -> None:
        if self.fixed_layout is not None:
            self.perception.set_layout(self.fixed_layout)
        else:
            self.on(TaskLayout, self._on_layout)
        self.on(Action, self._on_action)
        self.on(JointState, self._on_joint_state)
        if self.source is None:
            camera = self.perception.camera
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
    def _on_layout(self, layout: TaskLayout) -> None:
        self.perception.set_layout(layout)

    def _on_action(self, action: Action) -> None:
        self.perception.world.on_action(action.episode_id, action.object_id, action.goal_id)

    def _on_joint_state(self, state: JointState) -> None:
        self.perception.world.on_gripper(state.gripper_width)

    def _on_info(self, info: CameraInfo) -> None:
        calibration = self.perception.calibration
        if (info.width, info.height) != (calibration.width, calibration.height):
            raise ConfigError(
                "calibration",
                f"is for {calibration.width} x {calibration.height} images, "
                f"camera '{info.camera}' sends {info.width} x {info.height}",
            )

    def _image_arrived(self, image: CompressedImage) -> None:
        # Zenoh thread: keep only the newest; schedule one processing if none is waiting.
        with self._lock:
            waiting = self._latest is not None
            self._latest = image
        if not waiting:
            self.call_soon(self._process_latest)

    def _process_latest(self, _: object = None) -> None:
        with self._lock:
            image, self._latest = self._latest, None
        if image is None:
            return
        layout = self.perception.layout
        if layout is not None and image.stamp < layout.stamp:
            return  # taken before this episode was laid out
        scene, detections = self.perception.process_image(image, time.time())
        self._publish(scene, detections)

    def _publish(self, scene: Scene | None, detections: MarkerDetections | None) -> None:
        if scene is not None and not scene.stale and self.last_error.startswith(_NO_FRAME):
            self.last_error = ""
        if detections is not None:
            self.bus.publish(detections)
        if scene is not None:
            self.bus.publish(scene)

    # --- periodic ---------------------------------------------------------------------------
    def tick(self) -> None:
        now = time.time()
        if self.source is not None:
            try:
                grey = self.source.read()
            except ConfigError as exc:
                self.report_error(exc)
                self.failed = True
                self.stop_event.set()
                return
            if grey is None:
                self.perception.counters.corrupt += 1
            else:
                self._publish(*self.perception.process(grey, now, now))
            return
        # No frames lately: say so in the status (a Scene is only made from a frame, so a
        # planner never takes an old world for one observed after its last skill).
        world = self.perception.world
        if world.layout is not None and world.stale(now) and now - self._last_stale_report > 5:
            self._last_stale_report = now
            waited = f"for {now - world.last_frame:.0f} s" if world.last_frame else "yet"
            self.last_error = f"{_NO_FRAME} {waited}"

    def report_error(self, error: BaseException) -> None:
        # An OpenCV error that got past the pipeline's own names: its short name, not its
        # source path and assertion text.
        if isinstance(error, cv2.error):
            error = ManigraphError(opencv_reason(error, "handling a message"))
        super().report_error(error)

    def publish_status(self, state: ServiceState, detail: str = "") -> None:
        summary = self.perception.counters.summary()
        super().publish_status(state, f"{detail}; {summary}" if detail else summary)
