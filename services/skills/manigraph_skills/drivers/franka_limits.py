"""The Panda's limits, and the check every trajectory passes before it reaches the robot.

Limits are Franka's datasheet values for the Panda (FER): joint positions, velocities and
accelerations. A trajectory's velocities and accelerations are its finite differences as
timed for the robot (the planner's times over ``speed_factor``): velocity between
consecutive points, acceleration from consecutive velocities, with the arm at rest before the
first point and after the last. The TCP of every point must lie in the workspace box.

A violation raises ``SkillError('limit_exceeded')`` naming the joint (or the axis), the point
and both values, before anything moves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import JointTrajectoryCommand
from manigraph_shared.panda import ARM_JOINTS
from manigraph_shared.workspace import Workspace
from manigraph_skills.motion import PandaModel

#: Franka Panda datasheet limits, in ``ARM_JOINTS`` order.
Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
DQ_MAX = np.array([2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100])  # rad/s
DDQ_MAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])  # rad/s^2


@dataclass(frozen=True)
class TrajectoryReport:
    """What a validated trajectory asks of the arm (for the dry run's log line)."""

    points: int
    duration: float  # s, as the robot runs it
    peak_velocity_ratio: float  # highest |dq| / limit over every joint and segment
    peak_acceleration_ratio: float
    tcp_low: np.ndarray  # lowest x, y, z the TCP reaches, metres
    tcp_high: np.ndarray


class TrajectoryLimits:
    """Checks joint trajectories against the Panda's limits and a TCP workspace."""

    def __init__(
        self,
        model: PandaModel,
        workspace: Workspace,
        joint_margin: float = 0.0,
        limit_fraction: float = 1.0,
    ) -> None:
        self.model = model
        self.workspace = workspace
        self.lower = Q_MIN + joint_margin
        self.upper = Q_MAX - joint_margin
        self.velocity = DQ_MAX * limit_fraction
        self.acceleration = DDQ_MAX * limit_fraction

    def check(self, command: JointTrajectoryCommand, slowdown: float = 1.0) -> TrajectoryReport:
        """The trajectory's demands when run ``slowdown`` times slower than planned; raises
        ``SkillError('limit_exceeded')`` on any violation."""
        if tuple(command.joint_names) != ARM_JOINTS:
            raise SkillError("limit_exceeded", f"unexpected joints {command.joint_names}")
        times = np.array([p.time_from_start for p in command.points]) * slowdown
        q = np.array([p.positions for p in command.points])
        self._positions(q)
        velocity_ratio, acceleration_ratio = self._dynamics(times, q)
        tcp = np.array([self.model.tcp_pose(row).translation for row in q])
        self._workspace(tcp)
        return TrajectoryReport(
            points=len(times),
            duration=float(times[-1]),
            peak_velocity_ratio=velocity_ratio,
            peak_acceleration_ratio=acceleration_ratio,
            tcp_low=tcp.min(axis=0),
            tcp_high=tcp.max(axis=0),
        )

    def _positions(self, q: np.ndarray) -> None:
        for index, row in enumerate(q):
            for joint in np.flatnonzero((row < self.lower) | (row > self.upper)):
                raise SkillError(
                    "limit_exceeded",
                    f"{ARM_JOINTS[joint]} at {row[joint]:.3f} rad (point {index}) is outside "
                    f"[{self.lower[joint]:.3f}, {self.upper[joint]:.3f}]",
                )

    def _dynamics(self, times: np.ndarray, q: np.ndarray) -> tuple[float, float]:
        if len(times) < 2:
            return 0.0, 0.0
        dt = np.diff(times)
        velocity = np.diff(q, axis=0) / dt[:, None]  # between points i and i + 1
        ratio = np.abs(velocity) / self.velocity
        segment, joint = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        if ratio[segment, joint] > 1.0:
            raise SkillError(
                "limit_exceeded",
                f"{ARM_JOINTS[joint]} velocity {velocity[segment, joint]:.2f} rad/s between "
                f"points {segment} and {segment + 1} exceeds {self.velocity[joint]:.3f} rad/s",
            )
        # At rest before the first point and after the last; each velocity holds over its
        # segment, so the change between two happens over half of each.
        padded = np.vstack([np.zeros(q.shape[1]), velocity, np.zeros(q.shape[1])])
        spans = np.concatenate([[dt[0]], dt, [dt[-1]]])
        between = (spans[:-1] + spans[1:]) / 2
        acceleration = np.diff(padded, axis=0) / between[:, None]  # at each point
        accel_ratio = np.abs(acceleration) / self.acceleration
        point, joint = np.unravel_index(int(np.argmax(accel_ratio)), accel_ratio.shape)
        if accel_ratio[point, joint] > 1.0:
            raise SkillError(
                "limit_exceeded",
                f"{ARM_JOINTS[joint]} acceleration {acceleration[point, joint]:.1f} rad/s^2 "
                f"at point {point} exceeds {self.acceleration[joint]:.1f} rad/s^2",
            )
        return float(ratio.max()), float(accel_ratio.max())

    def _workspace(self, tcp: np.ndarray) -> None:
        box = (self.workspace.x, self.workspace.y, self.workspace.z)
        for index, point in enumerate(tcp):
            for axis, (low, high) in enumerate(box):
                if not low <= point[axis] <= high:
                    raise SkillError(
                        "limit_exceeded",
                        f"TCP {'xyz'[axis]} = {point[axis]:.3f} m at point {index} is outside "
                        f"the workspace [{low}, {high}]",
                    )
