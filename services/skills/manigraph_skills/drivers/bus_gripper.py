"""The geometric sim's robot: Cartesian gripper commands over the bus, one answer each."""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

from manigraph_shared.bus import Bus
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import GripperOp, RobotCommand, RobotFeedback
from manigraph_skills.drivers.base import Motion, RobotDriver


class BusGripperDriver(RobotDriver):
    """Sends ``RobotCommand`` on ``manigraph/robot/command`` and waits for its feedback.
    Registered as ``sim-gripper``; ignores the motion's grasp (the gripper is magic)."""

    name = "sim-gripper"

    def __init__(self, bus: Bus, timeout: float = 10.0) -> None:
        self.bus = bus
        self.timeout = timeout
        self._ids = itertools.count()
        self._waiting: dict[str, threading.Event] = {}
        self._answers: dict[str, RobotFeedback] = {}
        self._lock = threading.Lock()
        bus.subscribe(RobotFeedback, self._on_feedback)

    def _on_feedback(self, feedback: RobotFeedback) -> None:
        with self._lock:
            event = self._waiting.get(feedback.command_id)
            if event is not None:
                self._answers[feedback.command_id] = feedback
                event.set()

    def _send(self, op: GripperOp, motion: Motion) -> None:
        command_id = f"{motion.decision_id}.{next(self._ids)}"
        event = threading.Event()
        with self._lock:
            self._waiting[command_id] = event
        try:
            self.bus.publish(
                RobotCommand(
                    command_id=command_id,
                    decision_id=motion.decision_id,
                    op=op,
                    object_id=motion.object_id,
                    position=motion.position,
                    orientation=motion.orientation,
                    stamp=time.time(),
                )
            )
            if not event.wait(self.timeout):
                raise SkillError("driver_timeout", f"no answer to {op} within {self.timeout} s")
            feedback = self._answers.pop(command_id)
        finally:
            with self._lock:
                self._waiting.pop(command_id, None)
        if not feedback.ok:
            raise SkillError(feedback.reason or "driver_error", feedback.detail)

    @classmethod
    def from_options(cls, bus: Bus, options: Any) -> BusGripperDriver:
        return cls(bus, options.timeout)

    def pick(self, motion: Motion) -> None:
        self._send(GripperOp.PICK, motion)

    def place(self, motion: Motion) -> None:
        self._send(GripperOp.PLACE, motion)
