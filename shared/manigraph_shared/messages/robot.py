"""The robot-driver boundary: commands skills send and the driver's answers."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, ClassVar

from msgspec import Meta

from manigraph_shared.messages import legacy
from manigraph_shared.messages.base import (
    Delivery,
    Identifier,
    Message,
    Quaternion,
    Stamp,
    Vector3,
)


class GripperOp(StrEnum):
    #: Close on ``object_id`` at ``position`` and lift it clear.
    PICK = "pick"
    #: Lower the held object to ``position``, turned to ``orientation``, and open.
    PLACE = "place"
    #: Operate fixture ``object_id`` by its handle at ``position``, as its family says (a
    #: rack: pull it out, or push it in).
    OPERATE = "operate"


class RobotCommand(Message, frozen=True, kw_only=True):
    """One Cartesian gripper command for a robot driver (the geometric world's robot)."""

    key: ClassVar[str] = "manigraph/robot/command"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "skills"

    command_id: Identifier
    decision_id: Identifier
    op: GripperOp
    object_id: Identifier
    position: Annotated[Vector3, Meta(description="grasp or release position of the object centre")]
    orientation: Annotated[
        Quaternion, Meta(description="the object's orientation at grasp or at release")
    ] = Quaternion()
    stamp: Stamp

    @classmethod
    def upgrade(cls, data: dict[str, Any]) -> dict[str, Any]:
        """A command of contract version 1-3 in this version's fields (:mod:`.legacy`)."""
        return legacy.robot_command(data)


class DriverAnswer(Message, frozen=True, kw_only=True):
    """What a robot driver says of one command it was given: which command, whether it was
    done and why not. Each driver answer extends it (``RobotFeedback``,
    ``JointTrajectoryResult``); it has no key of its own."""

    command_id: Identifier
    ok: bool
    reason: Annotated[
        Annotated[str, Meta(max_length=64)] | None, Meta(description="why it failed")
    ] = None
    detail: Annotated[str, Meta(max_length=1024)] = ""


class RobotFeedback(DriverAnswer, frozen=True, kw_only=True):
    """The driver's answer to one ``RobotCommand``."""

    key: ClassVar[str] = "manigraph/robot/feedback"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "sim or robot driver"

    stamp: Stamp
