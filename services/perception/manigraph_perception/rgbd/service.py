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

import cv2
import msgspec

from manigraph_perception.image_guard import (
    ImageProblem,
    depth_problem,
    opencv_reason,
    size_problem,
)
from manigraph_perception.rgbd.pairing import HalfBuffer
from manigraph_perception.rgbd.pipeline import BadFrame, RgbdPerception
from manigraph_perception.rgbd.sources import RgbdFrame, RgbdSource, decode_pair
from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError, ManigraphError
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
from manigraph_shared.service import Service, malloc_trim

_NO_FRAME = "no usable frame"
#: Halves let go or refused since the last heap trim that make another worthwhile: each
#: was a ~0.5-1 MB sample, freed into glibc's heap, which keeps it otherwise (10,000
#: unpaired halves of 400 kB left +256 MB without a trim).
TRIM_AFTER_HALVES = 200
#: Halves refused from their header republish the last good Scene (stale) at most this often.
REFUSED_REPORT_SECONDS = 1.0


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
        #: Halves of frames waiting for their other half, by sequence (bounded: pairing.py).
        self._depths: HalfBuffer[DepthImage] = HalfBuffer()
        self._images: HalfBuffer[CompressedImage] = HalfBuffer()
        self._waiting: tuple[CompressedImage, DepthImage] | None = None
        #: The newest half refused from its header, waiting to be named in the status.
        self._refused: BadFrame | None = None
        self._halves_refused = 0
        self._refused_counts: dict[str, int] = {}  # by kind, not yet in the counters
        self._refused_reported_at = -REFUSED_REPORT_SECONDS
        self._halves_at_trim = 0
        self._halves_last_tick = 0
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
        # Zenoh thread. The header first: a few bytes read, nothing decoded.
        calibration = self.perception.calibration
        problem = depth_problem(depth.data, calibration.width, calibration.height)
        if problem is not None:
            self._refuse(depth, problem)
            return
        with self._lock:
            image = self._images.pop(depth.sequence)
            if image is None:
                self._depths.hold(depth.sequence, depth)
                self._count_unpaired()
                return
        self._pair(image, depth)

    def _image_arrived(self, image: CompressedImage) -> None:
        calibration = self.perception.calibration  # Zenoh thread, as above
        problem = size_problem("colour image", image.data, calibration.width, calibration.height)
        if problem is not None:
            self._refuse(image, problem)
            return
        with self._lock:
            depth = self._depths.pop(image.sequence)
            if depth is None:
                self._images.hold(image.sequence, image)  # its depth may come next
                self._count_unpaired()
                return
        self._pair(image, depth)

    def _count_unpaired(self) -> None:
        self.perception.counters.unpaired = self._depths.dropped + self._images.dropped

    def _refuse(self, half: DepthImage | CompressedImage, problem: ImageProblem) -> None:
        """Zenoh thread: a half refused from its header, neither held nor decoded. Counted
        among the rejections and named in the status (one report waits at most, so a flood
        of them costs the service thread one turn, not one per half); its partner, if it
        comes, waits for another, and a camera's own half of that sequence still pairs."""
        self.reject(half, problem.kind, f"#{half.sequence}: {problem.reason}")
        with self._lock:
            self._halves_refused += 1
            self._refused_counts[problem.kind] = self._refused_counts.get(problem.kind, 0) + 1
            pending = self._refused is not None
            self._refused = BadFrame(problem.kind, f"frame {half.sequence}: {problem.reason}")
        if not pending:
            self.call_soon(self._report_refused)

    def _report_refused(self, _: object = None) -> None:
        with self._lock:
            problem, self._refused = self._refused, None
            counts, self._refused_counts = self._refused_counts, {}
        for kind, count in counts.items():
            setattr(self.perception.counters, kind, getattr(self.perception.counters, kind) + count)
        if problem is None:
            return
        # The last good Scene again, stale, as for any bad frame, but at most once a
        # REFUSED_REPORT_SECONDS: a forger sends refused halves as fast as it likes, and
        # each is logged among the rejections already.
        now = time.monotonic()
        if now - self._refused_reported_at >= REFUSED_REPORT_SECONDS:
            self._refused_reported_at = now
            self._bad(problem)
        else:
            self._bad(problem, republish=False)

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
        calibration = self.perception.calibration
        try:
            frame = decode_pair(*pair, calibration.width, calibration.height)
        except BadFrame as exc:
            self.perception.count(exc)
            self._bad(exc)
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
            missing = self.perception.missing
            if missing:  # appearance identity: no Scene until every object is found
                self.last_error = f"not found yet: {', '.join(missing[:8])}" + (
                    f" and {len(missing) - 8} more" if len(missing) > 8 else ""
                )
            return
        if not scene.stale:
            self.last_good = scene
            self._problem = ""
            self.last_error = ""
        self.bus.publish(scene)

    def _bad(self, problem: BadFrame, republish: bool = True) -> None:
        """Name the problem in the status; serve the last good Scene again, stale, with its
        own (old) stamp (``republish``: and log it, if it is new)."""
        age = ""
        if self.last_good is not None:
            age = f"; last good scene {time.time() - self.last_good.stamp:.1f} s old"
            if republish:
                self.bus.publish(msgspec.structs.replace(self.last_good, stale=True))
        if republish and str(problem) != self._problem:
            self.log.warning("frame skipped: %s", problem)
        self._problem = str(problem)
        self.last_error = f"{problem}{age}"

    # --- periodic ---------------------------------------------------------------------------
    def tick(self) -> None:
        now = time.time()
        self._trim_after_flood()
        if self.source is not None:
            try:
                frame = self.source.read()
            except ConfigError as exc:
                self.report_error(exc)
                self.failed = True
                self.stop_event.set()
                return
            except BadFrame as exc:
                self.perception.count(exc)
                self._bad(exc)
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
            # A frame refused meanwhile (a forged 18000 x 18000 depth) stays named beside it.
            refused = f"; last refused: {self._problem}" if self._problem else ""
            self.last_error = f"{_NO_FRAME} {waited}{age}{refused}"

    def _trim_after_flood(self) -> None:
        """Give the heap back while and after many halves are let go or refused (the base
        class trims after messages handled; halves are never handed to a handler): every
        ``TRIM_AFTER_HALVES``, and once more when they stop."""
        with self._lock:
            halves = self.perception.counters.unpaired + self._halves_refused
        since = halves - self._halves_at_trim
        quiet = halves == self._halves_last_tick
        self._halves_last_tick = halves
        if since >= TRIM_AFTER_HALVES or (since > 0 and quiet):
            self._halves_at_trim = halves
            malloc_trim()

    def report_error(self, error: BaseException) -> None:
        # An OpenCV error that got past the pipeline's own names: its short name, not its
        # source path and assertion text.
        if isinstance(error, cv2.error):
            error = ManigraphError(opencv_reason(error, "handling a message"))
        super().report_error(error)

    def publish_status(self, state: ServiceState, detail: str = "") -> None:
        summary = self.perception.counters.summary()
        super().publish_status(state, f"{detail}; {summary}" if detail else summary)
