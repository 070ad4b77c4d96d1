"""Damped-least-squares inverse kinematics, clamped to the joint limits.

Each iteration takes the TCP's pose error as a twist in its local frame,
``e = log6(T_current^-1 T_target)``, and steps

    dq = J^T (J J^T + lambda^2 I)^-1 e

(the damped least-squares / Levenberg-Marquardt step, which stays bounded near
singularities), then clamps ``q`` to the joint limits, so every returned configuration is
one the robot can take. A target is reached when the position error is below ``tol_position``
metres and the rotation error below ``tol_rotation`` radians; otherwise the result says why.

With ``elbow_push`` (a direction in the base frame, its length the gain) every solve also
swings the elbow that way in the arm's null space (the 7-joint Panda can swing its elbow
about the shoulder-wrist line without moving the hand): ``elbow_steps`` extra steps of
``dq = N (J_elbow^T push)`` with the damped projector ``N = I - J^+ J``, then the hand's
pose is converged again. The planner uses it for the re-plans with the elbow swung up or to
either side when a forearm would touch a tower beside the path.

A cold start (``restart=True``) that fails from ``seed`` tries once more from the home pose
turned towards the target (base joint at the target's bearing, wrist at its yaw); a point
along a path is solved from the previous point only, so the arm never jumps between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_skills.motion.model import HOME_Q, PandaModel, wrapped


@dataclass(frozen=True)
class IKResult:
    q: np.ndarray
    ok: bool
    position_error: float  # metres
    rotation_error: float  # radians
    iterations: int


@dataclass
class IKSolver:
    model: PandaModel
    damping: float = 1e-2
    step: float = 1.0
    max_iterations: int = 200
    tol_position: float = 1e-4
    tol_rotation: float = 1e-3
    elbow_push: tuple[float, float, float] = (0.0, 0.0, 0.0)  # null-space elbow swing
    elbow_steps: int = 5

    def __post_init__(self) -> None:
        if self.damping <= 0:
            raise ConfigError("ik.damping", "must be > 0")
        if not 0 < self.step <= 1:
            raise ConfigError("ik.step", "must be in (0, 1]")
        if self.max_iterations < 1:
            raise ConfigError("ik.max_iterations", "must be >= 1")

    def solve(
        self, target: pin.SE3, seed: np.ndarray | None = None, restart: bool = True
    ) -> IKResult:
        """The joint configuration nearest ``seed`` (by descent) that reaches ``target``."""
        result = self._descend(target, HOME_Q if seed is None else seed)
        if result.ok or not restart:
            return result
        bearing = float(np.arctan2(target.translation[1], target.translation[0]))
        yaw = float(np.arctan2(target.rotation[1, 0], target.rotation[0, 0]))
        turned = HOME_Q.copy()
        turned[0] = bearing
        turned[6] = HOME_Q[6] + bearing - (yaw - np.pi / 2)
        turned[6] = wrapped(turned[6])
        second = self._descend(target, turned)
        return second if second.ok else result

    def _descend(self, target: pin.SE3, seed: np.ndarray) -> IKResult:
        model = self.model
        q = model.clamp(np.array(seed, dtype=float))
        damping = np.eye(6) * self.damping**2
        position_error = rotation_error = np.inf
        push = np.asarray(self.elbow_push, dtype=float)
        lifts = self.elbow_steps if np.any(push) else 0
        for iteration in range(self.max_iterations + 1):
            jacobian = model.tcp_jacobian(q)
            current = model.data.oMf[model.tcp]
            error = pin.log6(current.actInv(target)).vector
            position_error = float(np.linalg.norm(target.translation - current.translation))
            rotation_error = float(np.linalg.norm(error[3:]))
            converged = position_error < self.tol_position and rotation_error < self.tol_rotation
            if converged and lifts == 0:
                return IKResult(q, True, position_error, rotation_error, iteration)
            if iteration == self.max_iterations:
                break
            inverse = jacobian.T @ np.linalg.inv(jacobian @ jacobian.T + damping)
            dq = inverse @ error
            if lifts > 0:
                lifts -= 1
                swing = model.elbow_jacobian(q).T @ push
                dq = dq + (np.eye(len(q)) - inverse @ jacobian) @ swing
            q = model.clamp(q + self.step * dq)
        return IKResult(q, False, position_error, rotation_error, self.max_iterations)

    def solve_or_raise(
        self, target: pin.SE3, seed: np.ndarray | None, what: str, restart: bool = True
    ) -> np.ndarray:
        """Like :meth:`solve`; raises ``SkillError('no_ik_solution')`` naming ``what``."""
        result = self.solve(target, seed, restart)
        if not result.ok:
            where = np.round(target.translation, 3).tolist()
            raise SkillError(
                "no_ik_solution",
                f"{what} at {where}: {result.position_error * 1000:.1f} mm, "
                f"{np.degrees(result.rotation_error):.1f} deg off after {result.iterations} steps",
            )
        return result.q
