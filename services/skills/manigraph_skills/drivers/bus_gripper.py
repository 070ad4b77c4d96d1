"""``sim-gripper``: the geometric sim's robot, Cartesian gripper commands over the bus."""

from __future__ import annotations

import threading
from typing import Any

from manigraph_shared.bus import Bus
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import RobotCommand, RobotFeedback
from manigraph_skills.drivers.gripper import GripperDriver


class BusGripperTransport:
    """Publishes ``RobotCommand`` on ``manigraph/robot/command`` and waits for its feedback."""

    def __init__(self, bus: Bus, timeout: float = 10.0) -> None:
        self.bus = bus
        self.timeout = timeout
        self._waiting: dict[str, threading.Event] = {}
        self._answers: dict[str, RobotFeedback] = {}
        self._interrupted: dict[str, str] = {}
        self._lock = threading.Lock()
        bus.subscribe(RobotFeedback, self._on_feedback)

    def _on_feedback(self, feedback: RobotFeedback) -> None:
        with self._lock:
            event = self._waiting.get(feedback.command_id)
            if event is not None:
                self._answers[feedback.command_id] = feedback
                event.set()

    def interrupt(self, reason: str) -> None:
        """Wake every waiting command: it fails with ``reason`` (a stop, a dead robot)."""
        with self._lock:
            for command_id, event in self._waiting.items():
                self._interrupted[command_id] = reason
                event.set()

    def execute(self, command: RobotCommand) -> RobotFeedback:
        key = command.command_id
        event = threading.Event()
        with self._lock:
            self._waiting[key] = event
        try:
            self.bus.publish(command)
            if not event.wait(self.timeout):
                raise SkillError(
                    "driver_timeout", f"no answer to {command.op} within {self.timeout} s"
                )
            with self._lock:
                reason = self._interrupted.get(key)
                if reason is not None:
                    raise SkillError(reason, f"{command.op} interrupted: {reason}")
                return self._answers.pop(key)
        finally:
            with self._lock:
                self._waiting.pop(key, None)
                self._answers.pop(key, None)
                self._interrupted.pop(key, None)


class BusGripperDriver(GripperDriver):
    """Registered as ``sim-gripper`` (options: ``registry.BusGripperOptions``)."""

    name = "sim-gripper"

    def __init__(self, bus: Bus, timeout: float = 10.0) -> None:
        super().__init__(BusGripperTransport(bus, timeout))

    @classmethod
    def from_options(cls, bus: Bus, options: Any) -> BusGripperDriver:
        return cls(bus, options.timeout)
