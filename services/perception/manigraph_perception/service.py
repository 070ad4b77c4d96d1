"""The perception service: any registered pipeline (``pipeline.py``, ``registry.py``) on the
bus. Frames from the bus (``manigraph/camera/<name>/<part>`` for each part the pipeline
declares) or from a source (a device, a recording) in; ``Scene`` and the pipeline's other
messages out.

Each part is checked from its header as it arrives (a Zenoh thread; nothing decoded, a
refused one never held), parts are joined by ``sequence`` in either order (``pairing.py``),
and whole frames are handled newest-first: a frame that arrives while one is being processed
replaces the waiting one instead of queueing behind it (bounded work per frame, HOUSE_STYLE
point 12).

A stale camera is treated the same whatever the pipeline (``pipeline.py``): a frame that
cannot be used and one no newer than the last used are named in the status with the age of
the last good Scene, which is published again, ``stale``, with its own (old) stamp, at most
once a second; no usable frame for ``--stale-after`` seconds is named in the status. At most
one Scene is published per frame received.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from functools import partial
from typing import Any

import cv2
import msgspec

from manigraph_perception.image_guard import ImageProblem, opencv_reason
from manigraph_perception.pairing import FrameAssembler
from manigraph_perception.pipeline import BadFrame, CameraPart, Frame, FrameSource, Pipeline
from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError, ManigraphError
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    JointState,
    Scene,
    ServiceState,
    TaskLayout,
)
from manigraph_shared.service import Service, malloc_trim

_NO_FRAME = "no usable frame"
#: Parts let go or refused since the last heap trim that make another worthwhile: each was
#: a ~0.5-1 MB sample, freed into glibc's heap, which keeps it otherwise (10,000 unpaired
#: depth halves of 400 kB left +256 MB without a trim).
TRIM_AFTER_HALVES = 200
#: The last good Scene is published again (stale) at most this often.
STALE_REPUBLISH_SECONDS = 1.0


class PerceptionService(Service):
    name = "perception"

    def __init__(
        self,
        bus: Bus,
        pipeline: Pipeline[Any],
        source: FrameSource[Any] | None = None,
        layout: TaskLayout | None = None,
        poll_period: float = 1 / 30,
    ) -> None:
        super().__init__(bus)
        self.pipeline = pipeline
        self.source = source
        self.fixed_layout = layout
        self.tick_period = poll_period if source is not None else 0.5
        self._lock = threading.Lock()
        #: Parts of frames waiting for the rest of their frame (bounded: pairing.py).
        self._parts: FrameAssembler[CameraPart] = FrameAssembler(pipeline.parts)
        self._waiting: Mapping[str, CameraPart] | None = None
        #: The newest part refused from its header, waiting to be named in the status.
        self._refused: BadFrame | None = None
        self._halves_refused = 0
        self._refused_counts: dict[str, int] = {}  # by kind, not yet in the counters
        self._stale_published_at = -STALE_REPUBLISH_SECONDS
        self._halves_at_trim = 0
        self._halves_last_tick = 0
        self.last_good: Scene | None = None
        self.failed = False
        #: When (this machine's clock) the last usable frame came, and its own stamp.
        self.last_frame = 0.0
        self._last_stamp = float("-inf")
        self._problem = ""  # the last bad frame's reason, logged once per change

    def setup(self) -> None:
        if self.fixed_layout is not None:
            self._set_layout(self.fixed_layout)
        else:
            self.on(TaskLayout, self._set_layout)
        self.on(Action, self._on_action)
        self.on(JointState, lambda state: self.pipeline.world.on_gripper(state.gripper_width))
        if self.source is None:
            camera = self.pipeline.camera
            for part, message_type in self.pipeline.parts.items():
                self.bus.subscribe(
                    message_type,
                    partial(self._part_arrived, part),
                    on_error=self._rejected,
                    key=f"manigraph/camera/{camera}/{part}",
                )
            self.on(CameraInfo, self._on_info, key=f"manigraph/camera/{camera}/info")

    def teardown(self) -> None:
        if self.source is not None:
            self.source.close()

    # --- inputs -----------------------------------------------------------------------------
    def _set_layout(self, layout: TaskLayout) -> None:
        known = self.pipeline.layout
        self.pipeline.set_layout(layout)
        if known is None or known.episode_id != layout.episode_id:
            self.last_good = None  # never served again as this episode's

    def _on_action(self, action: Action) -> None:
        self.pipeline.world.on_action(action.episode_id, action.object_id, action.goal_id)

    def _on_info(self, info: CameraInfo) -> None:
        calibration = self.pipeline.calibration
        if (info.width, info.height) != (calibration.width, calibration.height):
            raise ConfigError(
                "calibration",
                f"is for {calibration.width} x {calibration.height} images, "
                f"camera '{info.camera}' sends {info.width} x {info.height}",
            )

    def _part_arrived(self, part: str, message: CameraPart) -> None:
        # Zenoh thread. The header first: a few bytes read, nothing decoded.
        problem = self.pipeline.check(part, message.data)
        if problem is not None:
            self._refuse(message, problem)
            return
        with self._lock:
            frame = self._parts.add(part, message)
            self.pipeline.counters.unpaired = self._parts.dropped
            if frame is None:
                return  # the rest of its frame may come next
            waiting = self._waiting is not None
            self._waiting = frame  # only the newest whole frame waits
        if not waiting:
            self.call_soon(self._process_waiting)

    def _refuse(self, message: CameraPart, problem: ImageProblem) -> None:
        """Zenoh thread: a part refused from its header, neither held nor decoded. Counted
        among the rejections and named in the status (one report waits at most, so a flood
        of them costs the service thread one turn, not one per part); the rest of its frame,
        if it comes, waits for another, and a camera's own part of that sequence still joins."""
        self.reject(message, problem.kind, f"#{message.sequence}: {problem.reason}")
        with self._lock:
            self._halves_refused += 1
            self._refused_counts[problem.kind] = self._refused_counts.get(problem.kind, 0) + 1
            pending = self._refused is not None
            self._refused = BadFrame(problem.kind, f"frame {message.sequence}: {problem.reason}")
        if not pending:
            self.call_soon(self._report_refused)

    def _report_refused(self, _: object = None) -> None:
        with self._lock:
            problem, self._refused = self._refused, None
            counts, self._refused_counts = self._refused_counts, {}
        for kind, count in counts.items():
            for _ in range(count):
                self.pipeline.counters.count(kind)
        if problem is not None:
            self._bad(problem, log=False)  # logged among the rejections already

    def _process_waiting(self, _: object = None) -> None:
        with self._lock:
            parts, self._waiting = self._waiting, None
        if parts is None:
            return
        layout = self.pipeline.layout
        if layout is not None and next(iter(parts.values())).stamp < layout.stamp:
            return  # taken before this episode was laid out
        try:
            frame = self.pipeline.assemble(parts)
        except BadFrame as exc:
            self.pipeline.counters.count(exc.kind)
            self._bad(exc)
            return
        self._observe(frame)

    # --- frames -----------------------------------------------------------------------------
    def _observe(self, frame: Frame) -> None:
        if frame.stamp <= self._last_stamp:
            # Not a new observation: a frozen camera repeating itself, or one overtaken.
            self._bad(BadFrame("old", f"frame {frame.sequence} is no newer than the last one used"))
            return
        now = time.time()
        self.last_frame = now
        self._last_stamp = frame.stamp
        try:
            observation = self.pipeline.observe(frame, now)
        except BadFrame as exc:
            self._bad(exc)
            return
        for message in observation.messages:
            self.bus.publish(message)
        scene = observation.scene
        if scene is None:
            if observation.waiting:
                self.last_error = observation.waiting
            return
        if not scene.stale:
            self.last_good = scene
            self._problem = ""
            self.last_error = ""
        self.bus.publish(scene)

    def _note(self, problem: str, log: bool = True) -> None:
        if log and problem != self._problem:
            self.log.warning("frame skipped: %s", problem)
        self._problem = problem

    def _bad(self, problem: BadFrame, log: bool = True) -> None:
        """Name the problem in the status, with the age of the last good Scene; serve that
        Scene again, stale, with its own (old) stamp."""
        self._note(str(problem), log)
        self.last_error = f"{problem}{self._last_good_age(time.time())}"
        self._serve_stale()

    def _serve_stale(self) -> None:
        """The last good Scene again, ``stale``, at most once a ``STALE_REPUBLISH_SECONDS``
        (a forger sends refused parts as fast as it likes)."""
        now = time.monotonic()
        if self.last_good is None or now - self._stale_published_at < STALE_REPUBLISH_SECONDS:
            return
        self._stale_published_at = now
        self.bus.publish(msgspec.structs.replace(self.last_good, stale=True))

    def _last_good_age(self, now: float) -> str:
        if self.last_good is None:
            return ""
        return f"; last good scene {now - self.last_good.stamp:.1f} s old"

    # --- periodic ---------------------------------------------------------------------------
    def tick(self) -> None:
        self._trim_after_flood()
        if self.source is not None:
            self._read_source()
        now = time.time()
        stale_after = self.pipeline.world.config.stale_after
        if self.pipeline.layout is not None and now - self.last_frame > stale_after:
            waited = f"for {now - self.last_frame:.0f} s" if self.last_frame else "yet"
            # A frame refused meanwhile (a forged 18000 x 18000 depth) stays named beside it.
            refused = f"; last refused: {self._problem}" if self._problem else ""
            self.last_error = f"{_NO_FRAME} {waited}{self._last_good_age(now)}{refused}"

    def _read_source(self) -> None:
        assert self.source is not None
        try:
            frame = self.source.read()
        except ConfigError as exc:
            self.report_error(exc)
            self.failed = True
            self.stop_event.set()
            return
        except BadFrame as exc:
            self.pipeline.counters.count(exc.kind)
            self._bad(exc)
            return
        if frame is not None:
            self._observe(frame)

    def _trim_after_flood(self) -> None:
        """Give the heap back while and after many parts are let go or refused (the base
        class trims after messages handled; parts are never handed to a handler): every
        ``TRIM_AFTER_HALVES``, and once more when they stop."""
        with self._lock:
            halves = self.pipeline.counters.unpaired + self._halves_refused
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
        summary = self.pipeline.counters.summary()
        super().publish_status(state, f"{detail}; {summary}" if detail else summary)
