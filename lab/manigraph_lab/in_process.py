"""Transports that carry a skills driver's commands straight into a sim backend, no bus.

They have the shapes of the skills' transports (``GripperTransport``, ``JointTransport``), so
the skills' own drivers run against a world in the same process: in-process episodes,
benchmarks and tests execute exactly what the services execute.
"""

from __future__ import annotations

import time

import numpy as np

from manigraph_shared.messages import (
    JointTrajectoryCommand,
    JointTrajectoryResult,
    RobotCommand,
    RobotFeedback,
)
from manigraph_sim.backend_base import SimBackend
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_skills.drivers.joint_transport import position_in


class InProcessGripperTransport:
    """Gripper commands executed by ``backend`` at the stamp each command carries."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend

    def execute(self, command: RobotCommand) -> RobotFeedback:
        return self.backend.execute(command, command.stamp)

    def interrupt(self, reason: str) -> None:
        """Nothing waits: a command is carried out within ``execute``."""


class InProcessJointTransport:
    """Joint trajectories executed by a physics backend, for tests and benchmarks."""

    def __init__(self, backend: PhysicsBackend) -> None:
        self.backend = backend

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        return self.backend.execute_trajectory(command, time.time())

    def joint_positions(self) -> np.ndarray:
        state = self.backend.joint_state(time.time())
        if state is None:
            raise RuntimeError("no episode has been reset yet")
        return np.array(state.positions)

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        scene = self.backend.scene(time.time())
        if scene is None:
            return None
        return position_in(scene, object_id)

    def stop(self) -> None:
        self.backend.emergency_stop(True)

    def resume(self) -> None:
        self.backend.emergency_stop(False)

    def abort(self, reason: str) -> None:
        """In process the world cannot go away between calls: there is nothing to abort."""
