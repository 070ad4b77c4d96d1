"""The geometric sim's robot: Cartesian gripper commands over the bus, one answer each."""

from __future__ import annotations

import itertools
import threading
import time

from manigraph_shared.bus import Bus
from manigraph_shared.errors import SkillError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import GripperOp, Quaternion, RobotCommand, RobotFeedback, Vector3
from manigraph_skills.drivers.base import CENTRE_GRASP, Grasp, RobotDriver, register_driver


@register_driver("sim-gripper")
class BusGripperDriver(RobotDriver):
    """Sends ``RobotCommand`` on ``manigraph/robot/command`` and waits for its feedback."""

    def __init__(self, bus: Bus, timeout: float = 10.0) -> None:
        self.bus = bus
        self.timeout = timeout
        self._ids = itertools.count()
        self._waiting: dict[str, threading.Event] = {}
        self._answers: dict[str, RobotFeedback] = {}
        self._lock = threading.Lock()
        self._stopped = threading.Event()
        self._aborted: dict[str, str] = {}
        bus.subscribe(RobotFeedback, self._on_feedback)

    def stop(self) -> None:
        self._stopped.set()
        with self._lock:
            for event in self._waiting.values():
                event.set()  # wake the waiting skill: it sees the stop and gives up

    def resume(self) -> None:
        self._stopped.clear()

    def abort(self, reason: str) -> None:
        with self._lock:
            for command_id, event in self._waiting.items():
                self._aborted[command_id] = reason
                event.set()

    def _on_feedback(self, feedback: RobotFeedback) -> None:
        with self._lock:
            event = self._waiting.get(feedback.command_id)
            if event is not None:
                self._answers[feedback.command_id] = feedback
                event.set()

    def _send(
        self,
        op: GripperOp,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
    ) -> None:
        if self._stopped.is_set():
            raise SkillError("stopped", "emergency stop engaged")
        command_id = derived_id(decision_id, ".", str(next(self._ids)))
        event = threading.Event()
        with self._lock:
            self._waiting[command_id] = event
        try:
            self.bus.publish(
                RobotCommand(
                    command_id=command_id,
                    decision_id=decision_id,
                    op=op,
                    object_id=object_id,
                    position=position,
                    orientation=orientation,
                    stamp=time.time(),
                )
            )
            if not event.wait(self.timeout):
                raise SkillError("driver_timeout", f"no answer to {op} within {self.timeout} s")
            if self._stopped.is_set():
                raise SkillError("stopped", f"emergency stop during {op}")
            if command_id in self._aborted:
                raise SkillError(self._aborted[command_id], f"the robot went away during {op}")
            feedback = self._answers.pop(command_id)
        finally:
            with self._lock:
                self._waiting.pop(command_id, None)
                self._answers.pop(command_id, None)
                self._aborted.pop(command_id, None)
        if not feedback.ok:
            raise SkillError(feedback.reason or "driver_error", feedback.detail)

    def pick(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
    ) -> None:
        self._send(GripperOp.PICK, decision_id, object_id, position, orientation)

    def place(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
    ) -> None:
        self._send(GripperOp.PLACE, decision_id, object_id, position, orientation)
