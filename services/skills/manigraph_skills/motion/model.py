"""The Panda's kinematic model, built by Pinocchio from the URDF shipped with mani-skill.

The sim's physics Panda is loaded from the same file, so planned and simulated kinematics
agree exactly. The two finger joints are locked: the arm model has the 7 arm joints only,
and the gripper is commanded separately.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from manigraph_shared.errors import ConfigError
from manigraph_shared.panda import (  # noqa: F401  (re-exported for the motion package)
    ARM_JOINTS,
    FINGER_JOINTS,
    FINGER_OPEN,
    HOME_Q,
    TCP_FRAME,
    panda_urdf_path,
)


#: The arm's joints, in the order every joint vector in manigraph uses.
class PandaModel:
    """Forward kinematics and Jacobians of the 7-joint arm at the TCP frame."""

    def __init__(self, urdf: Path | None = None) -> None:
        self.urdf = urdf or panda_urdf_path()
        full = pin.buildModelFromUrdf(str(self.urdf))
        locked = [full.getJointId(name) for name in FINGER_JOINTS]
        self.model = pin.buildReducedModel(full, locked, pin.neutral(full))
        self.data = self.model.createData()
        self.tcp = self.model.getFrameId(TCP_FRAME)
        self.elbow = self.model.getFrameId("panda_link4")
        self.lower = self.model.lowerPositionLimit.copy()
        self.upper = self.model.upperPositionLimit.copy()
        self.velocity_limit = self.model.velocityLimit.copy()
        names = [self.model.names[i] for i in range(1, self.model.njoints)]
        if tuple(names) != ARM_JOINTS:
            raise ConfigError("panda_urdf", f"unexpected arm joints {names}")

    @property
    def joint_names(self) -> tuple[str, ...]:
        return ARM_JOINTS

    def clamp(self, q: np.ndarray) -> np.ndarray:
        return np.clip(q, self.lower, self.upper)

    def within_limits(self, q: np.ndarray, margin: float = 1e-9) -> bool:
        return bool(np.all(q >= self.lower - margin) and np.all(q <= self.upper + margin))

    def tcp_pose(self, q: np.ndarray) -> pin.SE3:
        """The TCP's pose in the robot base frame."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.tcp].copy()

    def tcp_jacobian(self, q: np.ndarray) -> np.ndarray:
        """6x7 Jacobian of the TCP in its local frame (also updates the TCP placement)."""
        pin.computeJointJacobians(self.model, self.data, q)  # also runs forward kinematics
        pin.updateFramePlacement(self.model, self.data, self.tcp)
        return pin.getFrameJacobian(self.model, self.data, self.tcp, pin.LOCAL)

    def elbow_jacobian(self, q: np.ndarray) -> np.ndarray:
        """3x7: how the elbow moves in the base frame per joint; call after
        :meth:`tcp_jacobian` at ``q`` (the joint Jacobians are ready then)."""
        pin.updateFramePlacement(self.model, self.data, self.elbow)
        jacobian = pin.getFrameJacobian(self.model, self.data, self.elbow, pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(jacobian[:3], dtype=float)


def wrapped(angle: float) -> float:
    """``angle`` in [-pi, pi), radians: the same turn, the short way round."""
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def top_down(position: np.ndarray, yaw: float = 0.0) -> pin.SE3:
    """A TCP pose at ``position`` with the fingers pointing straight down, rotated by ``yaw``
    about the vertical (yaw 0: fingers close along the base frame's y axis)."""
    c, s = np.cos(yaw), np.sin(yaw)
    rotation = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
    return pin.SE3(rotation, np.asarray(position, dtype=float))
