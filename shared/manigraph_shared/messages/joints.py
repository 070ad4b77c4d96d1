"""The joint-level robot boundary: trajectories skills plan, and the arm's joint state.

A driver that plans its own motion (the ``panda-sim`` driver, later a Franka driver) sends one
``JointTrajectoryCommand`` per motion and waits for its ``JointTrajectoryResult``; the robot
also streams ``JointState``. Angles are radians, in ``joint_names`` order.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Annotated, ClassVar

from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct
from manigraph_shared.messages.robot import DriverAnswer

MAX_JOINTS = 16
MAX_POINTS = 4096

#: Joint angles are plain floats in lists (so the README table reads list[float]); they are
#: checked against this bound by the messages' validators.
MAX_RADIANS = 2 * math.pi
FingerWidth = Annotated[
    float, Meta(ge=0.0, le=0.2, description="distance between the fingers, metres")
]


class GripperTarget(StrEnum):
    OPEN = "open"
    CLOSED = "closed"


class JointTrajectoryPoint(Struct, frozen=True, kw_only=True):
    """Joint positions to reach at ``time_from_start``; the gripper is driven to ``gripper``
    while the arm moves towards this point, open as wide as ``opening`` (a dish between
    neighbours is taken with the fingers open little wider than it)."""

    positions: Annotated[
        list[float], Meta(max_length=MAX_JOINTS, description="radians, within +-2 pi")
    ]
    gripper: GripperTarget
    opening: Annotated[
        FingerWidth | None,
        Meta(description="distance between the open fingers, metres; None: fully open"),
    ] = None
    time_from_start: Annotated[float, Meta(ge=0.0, le=3600.0, description="seconds")]

    def _check(self) -> None:
        _check_angles(self.positions)


class JointTrajectoryCommand(Message, frozen=True, kw_only=True):
    """A timed joint trajectory for the arm, with gripper targets, for one motion."""

    key: ClassVar[str] = "manigraph/robot/joint_trajectory"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "skills"

    command_id: Identifier
    decision_id: Identifier
    joint_names: Annotated[
        list[str],
        Meta(min_length=1, max_length=MAX_JOINTS, description="order of every point's positions"),
    ]
    points: Annotated[list[JointTrajectoryPoint], Meta(min_length=1, max_length=MAX_POINTS)]
    stamp: Stamp

    def _check(self) -> None:
        _check_names(self.joint_names)
        for index, point in enumerate(self.points):
            if len(point.positions) != len(self.joint_names):
                raise ValueError(
                    f"points: point {index} has {len(point.positions)} positions for "
                    f"{len(self.joint_names)} joints"
                )
            if index and point.time_from_start <= self.points[index - 1].time_from_start:
                raise ValueError(f"points: time_from_start of point {index} must increase")


class JointTrajectoryResult(DriverAnswer, frozen=True, kw_only=True):
    """The robot's answer to one ``JointTrajectoryCommand``, with the state it ended in."""

    key: ClassVar[str] = "manigraph/robot/joint_trajectory_result"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "sim or robot driver"

    positions: Annotated[
        list[float], Meta(max_length=MAX_JOINTS, description="final arm joints, radians")
    ]
    gripper_width: FingerWidth
    stamp: Stamp

    def _check(self) -> None:
        _check_angles(self.positions)


class JointState(Message, frozen=True, kw_only=True):
    """The arm's joint positions and the gripper opening at one instant."""

    key: ClassVar[str] = "manigraph/robot/joint_state"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim or robot driver"

    joint_names: Annotated[list[str], Meta(max_length=MAX_JOINTS, description="joint order")]
    positions: Annotated[
        list[float], Meta(max_length=MAX_JOINTS, description="radians, within +-2 pi")
    ]
    gripper_width: FingerWidth
    stamp: Stamp

    def _check(self) -> None:
        if len(self.positions) != len(self.joint_names):
            raise ValueError("positions: one value per joint name")
        _check_angles(self.positions)
        _check_names(self.joint_names)


def _check_angles(positions: list[float]) -> None:
    if any(abs(q) > MAX_RADIANS for q in positions):
        raise ValueError("positions: every angle must be within +-2 pi radians")


def _check_names(names: list[str]) -> None:
    if any(not 1 <= len(name) <= 64 for name in names):
        raise ValueError("joint_names: every name must have 1-64 characters")
