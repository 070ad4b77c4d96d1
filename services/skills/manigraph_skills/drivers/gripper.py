"""A Cartesian gripper: pick at a pose, place at a pose, one ``RobotCommand`` each.

The geometric world's robot. How a command reaches the world is the transport's business: over
the bus (``sim-gripper``) or straight into a backend in the same process (in-process episodes),
so both run the very same driver.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

from manigraph_shared.errors import SkillError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import (
    GripperOp,
    Quaternion,
    RobotCommand,
    RobotFeedback,
)
from manigraph_skills.drivers.base import Motion, RobotDriver, TrayToggle


class GripperTransport(Protocol):
    def execute(self, command: RobotCommand) -> RobotFeedback:
        """Carry out ``command`` and return the world's answer (raise ``SkillError`` if none)."""

    def interrupt(self, reason: str) -> None:
        """Fail the command under way now with ``reason`` (a transport that never waits has
        nothing to interrupt)."""


class GripperDriver(RobotDriver):
    """Sends one ``RobotCommand`` per pick and per place and raises on a refusal."""

    def __init__(self, transport: GripperTransport, clock: Callable[[], float] = time.time) -> None:
        self.transport = transport
        self.clock = clock
        self._stopped = False

    def stop(self) -> None:
        self._stopped = True
        self.transport.interrupt("stopped")

    def resume(self) -> None:
        self._stopped = False

    def abort(self, reason: str) -> None:
        self.transport.interrupt(reason)

    def _send(self, op: GripperOp, motion: Motion) -> None:
        """One command; the motion's grasp is ignored (the gripper is magic)."""
        if self._stopped:
            raise SkillError("stopped", "emergency stop engaged")
        feedback = self.transport.execute(
            RobotCommand(
                command_id=derived_id(motion.decision_id, ".", op.value),
                decision_id=motion.decision_id,
                op=op,
                object_id=motion.object_id,
                position=motion.position,
                orientation=motion.orientation,
                stamp=self.clock(),
            )
        )
        if not feedback.ok:
            raise SkillError(feedback.reason or "driver_error", feedback.detail)

    def pick(self, motion: Motion) -> None:
        self._send(GripperOp.PICK, motion)

    def place(self, motion: Motion) -> None:
        self._send(GripperOp.PLACE, motion)

    def toggle_tray(self, toggle: TrayToggle) -> None:
        """One ``operate`` command naming the rack, at its handle."""
        motion = Motion(toggle.decision_id, toggle.rack_id, toggle.handle, Quaternion())
        self._send(GripperOp.OPERATE, motion)
