"""A Panda driver that plans its own motion: Pinocchio IK on the skill side, joint
trajectories to the robot. The robot end (sim or hardware) is a ``JointTransport``.

Checks, each reported as a ``SkillError`` reason:

* ``no_ik_solution``: a waypoint cannot be reached (nothing is sent to the robot);
* ``grasp_slipped``: after closing and lifting (or after the transfer) the fingers closed to
  less than ``min_grasp_width``, so nothing is between them;
* ``placement_missed``: after release the object's centre is more than
  ``placement_tolerance`` from the target (when the transport can observe objects).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from typing import Protocol

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import (
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    JointTrajectoryResult,
)
from manigraph_skills.drivers.base import Motion, RobotDriver
from manigraph_skills.drivers.registry import MotionOptions
from manigraph_skills.motion import GraspPlanner, JointTrajectory, PandaModel, PlanConfig
from manigraph_skills.motion.plan import UP, grasp_yaw


class JointTransport(Protocol):
    """Where joint trajectories go: the sim over the bus, a real arm, or a backend in-process."""

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        """Run ``command`` to the end and answer it."""
        ...

    def joint_positions(self) -> np.ndarray:
        """The arm's current joint positions, radians."""
        ...

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        """Where ``object_id`` is, observed after time ``after``; None if unknown."""
        ...

    def stop(self) -> None:
        """Emergency stop: make a running ``execute`` return or raise at once."""
        ...

    def resume(self) -> None:
        """Accept trajectories again."""
        ...

    def abort(self, reason: str) -> None:
        """The robot went away: make a running ``execute`` raise ``SkillError(reason)``."""
        ...


class PandaMotionDriver(RobotDriver):
    name = "panda-motion"

    def __init__(
        self,
        transport: JointTransport,
        options: MotionOptions | None = None,
        config: PlanConfig | None = None,
    ) -> None:
        options = options or MotionOptions()
        self.transport = transport
        self.model = PandaModel()
        self.planner = GraspPlanner(self.model, config)
        self.min_grasp_width = options.min_grasp_width
        self.placement_tolerance = options.placement_tolerance
        self._ids = itertools.count()
        self._stopped = False

    def pick(self, motion: Motion) -> None:
        decision_id, object_id, grasp = motion.decision_id, motion.object_id, motion.grasp
        position, orientation = motion.position, motion.orientation
        target = np.array(position.as_tuple()) + grasp.height * UP
        yaw = (
            self.planner.config.hand_yaw
            + grasp.turn
            + grasp_yaw((orientation.x, orientation.y, orientation.z, orientation.w))
        )
        result = self._run(decision_id, lambda q: self.planner.pick(q, target, yaw))
        if result.gripper_width < self.min_grasp_width:
            self._open(decision_id)
            raise SkillError(
                "grasp_slipped",
                f"fingers closed to {result.gripper_width * 1000:.1f} mm: {object_id} not held",
            )

    def place(self, motion: Motion) -> None:
        decision_id, object_id, grasp = motion.decision_id, motion.object_id, motion.grasp
        target = np.array(motion.position.as_tuple())
        hand = target + grasp.height * UP
        # The object turned with the hand at the grasp; turn back so it lands square (a
        # block or a square cover looks the same after a quarter turn).
        yaw = self.planner.config.hand_yaw + grasp.turn
        carry = self._run(
            decision_id, lambda q: self.planner.place(q, hand, yaw, carry_z=grasp.carry_z)
        )
        if carry.gripper_width < self.min_grasp_width:
            self._open(decision_id)
            raise SkillError("grasp_slipped", f"{object_id} was lost during the transfer")
        released = self._run(decision_id, self.planner.release)
        seen = self.transport.object_position(object_id, after=released.stamp)
        if seen is not None:
            miss = float(np.linalg.norm(seen - target))
            if miss > self.placement_tolerance:
                raise SkillError(
                    "placement_missed", f"{object_id} rests {miss * 1000:.0f} mm from its goal"
                )

    def stop(self) -> None:
        self._stopped = True
        self.transport.stop()

    def resume(self) -> None:
        self._stopped = False
        self.transport.resume()

    def abort(self, reason: str) -> None:
        abort = getattr(self.transport, "abort", None)
        if abort is not None:
            abort(reason)

    # --- pieces -----------------------------------------------------------------------------
    def _open(self, decision_id: str) -> None:
        """After a lost grasp: open and back off, so the next attempt starts clean."""
        self._run(decision_id, self.planner.release)

    def _run(
        self, decision_id: str, plan: Callable[[np.ndarray], JointTrajectory]
    ) -> JointTrajectoryResult:
        """Plan from the arm's joints and execute; plan once more if the arm was elsewhere."""
        if self._stopped:
            raise SkillError("stopped", "emergency stop engaged")
        q = self.transport.joint_positions()
        for _attempt in range(2):
            trajectory = plan(q)  # raises SkillError('no_ik_solution') before any motion
            result = self.transport.execute(self._command(decision_id, trajectory))
            if result.ok:
                return result
            if result.reason != "start_mismatch":
                raise SkillError(result.reason or "driver_error", result.detail)
            q = np.array(result.positions)
        raise SkillError("start_mismatch", "the arm keeps moving away from the planned start")

    def _command(self, decision_id: str, trajectory: JointTrajectory) -> JointTrajectoryCommand:
        return JointTrajectoryCommand(
            command_id=derived_id(decision_id, ".", str(next(self._ids))),
            decision_id=decision_id,
            joint_names=list(self.model.joint_names),
            points=[
                JointTrajectoryPoint(
                    positions=q.tolist(),
                    gripper=GripperTarget.CLOSED if closed else GripperTarget.OPEN,
                    time_from_start=t,
                )
                for t, q, closed in zip(
                    trajectory.times, trajectory.positions, trajectory.closed, strict=True
                )
            ],
            stamp=time.time(),
        )
