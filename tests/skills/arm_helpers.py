"""What the skills tests share: a block at a level of a tower, an ideal arm at the driver's
hardware boundary, and a sent trajectory command read back as the planner's trajectory."""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import (
    JointTrajectoryCommand,
    JointTrajectoryResult,
    ObjectCategory,
    SceneObject,
    Vector3,
)
from manigraph_skills.motion import HOME_Q, JointTrajectory

#: A block's side, metres.
BLOCK = 0.04


def block(name: str, x: float, y: float, level: int = 0) -> SceneObject:
    """A block standing at ``level`` (0: on the table) of a tower at ``x``, ``y``."""
    return SceneObject(
        id=name,
        category=ObjectCategory.BLOCK,
        position=Vector3(x=x, y=y, z=BLOCK / 2 + level * BLOCK),
        size=Vector3(x=BLOCK, y=BLOCK, z=BLOCK),
    )


class PerfectArm:
    """Executes every trajectory exactly and holds a block after closing; starts at ``q``
    (the home pose by default)."""

    def __init__(self, q: np.ndarray | None = None) -> None:
        self.q = HOME_Q.copy() if q is None else q
        self.sent: list[JointTrajectoryCommand] = []

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        self.sent.append(command)
        self.q = np.array(command.points[-1].positions)
        closed = command.points[-1].gripper.value == "closed"
        return JointTrajectoryResult(
            command_id=command.command_id,
            ok=True,
            positions=self.q.tolist(),
            gripper_width=0.04 if closed else 0.08,
            stamp=1.0,
        )

    def joint_positions(self) -> np.ndarray:
        return self.q.copy()

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        return None


def trajectory_of(command: JointTrajectoryCommand) -> JointTrajectory:
    trajectory = JointTrajectory()
    for point in command.points:
        trajectory.add(point.time_from_start, np.array(point.positions), point.gripper == "closed")
    return trajectory
