"""The physics backend as a joint transport without a bus, for tests and benchmarks.

It has the shape of the skills' ``JointTransport`` (``execute``, ``joint_positions``,
``object_position``), so a Panda motion driver can drive the simulated arm in the same process.
"""

from __future__ import annotations

import time

import numpy as np

from manigraph_shared.messages import JointTrajectoryCommand, JointTrajectoryResult
from manigraph_sim.physics.backend import PhysicsBackend


class InProcessTransport:
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
        return np.array(scene.object(object_id).position.as_tuple())

    def stop(self) -> None:
        self.backend.emergency_stop(True)

    def resume(self) -> None:
        self.backend.emergency_stop(False)
