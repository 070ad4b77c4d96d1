"""A Cartesian gripper: pick at a pose, place at a pose, one ``RobotCommand`` each.

The geometric world's robot. How a command reaches the world is the transport's business: over
the bus (``sim-gripper``) or straight into a backend in the same process (in-process episodes),
so both run the very same driver.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from typing import Protocol

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    GripperOp,
    Quaternion,
    RobotCommand,
    RobotFeedback,
    Vector3,
)
from manigraph_skills.drivers.base import Motion, RobotDriver


class GripperTransport(Protocol):
    def execute(self, command: RobotCommand) -> RobotFeedback:
        """Carry out ``command`` and return the world's answer (raise ``SkillError`` if none)."""


class GripperDriver(RobotDriver):
    """Sends one ``RobotCommand`` per pick and per place and raises on a refusal."""

    def __init__(self, transport: GripperTransport, clock: Callable[[], float] = time.time) -> None:
        self.transport = transport
        self.clock = clock

    def _send(self, op: GripperOp, motion: Motion) -> None:
        """One command; the motion's grasp is ignored (the gripper is magic)."""
        feedback = self.transport.execute(
            RobotCommand(
                command_id=command_id(motion.decision_id, op),
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

    def toggle_tray(self, decision_id: str, rack_id: str, handle: Vector3) -> None:
        """One ``toggle_tray`` command naming the rack, at its handle."""
        self._send(GripperOp.TOGGLE_TRAY, Motion(decision_id, rack_id, handle, Quaternion()))


def command_id(decision_id: str, op: GripperOp) -> str:
    """``<decision>.<op>``, or, for a decision id too long to extend within the contract's
    limit, a short digest of it: any valid decision id gives a valid command id."""
    suffix = f".{op.value}"
    if len(decision_id) + len(suffix) <= 64:
        return decision_id + suffix
    digest = hashlib.blake2s(decision_id.encode(), digest_size=8).hexdigest()
    return f"{digest}{suffix}"
