"""A top-down PickAndPlace as Cartesian waypoints, turned into joint trajectories by IK.

Pick: from where the hand is, up to a safe height, across, down to the *pregrasp* above the
object, straight down to the *grasp* (TCP at the object's centre), *close*, *lift*.
Place: up to the carry height, *transfer* across, down to *place* (object centre at the goal,
a few millimetres high so it is set down rather than pushed in). Release: open, *retreat* up.
Pick, place and release are separate motions so a driver can check the grasp between them.
Every straight segment is sampled every ``sample_spacing`` metres and solved by IK seeded with
the previous sample, so the hand really moves along the line and no joint flips between them.
"""

from __future__ import annotations

import contextlib
import copy
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_skills.motion.ik import IKSolver
from manigraph_skills.motion.model import HOME_Q, PandaModel, top_down, wrapped
from manigraph_skills.motion.trajectory import JointTrajectory

UP = np.array([0.0, 0.0, 1.0])
#: Radians between IK samples while the hand turns (``GraspPlanner.pose_line``), and the
#: most any joint may move between two samples.
ANGLE_SPACING = 0.05
MAX_JOINT_STEP = 0.3
#: Joint-space samples of a move home (``GraspPlanner.home``).
HOMING_SAMPLES = 30
#: How far a retreat draws back towards the robot (-x) when it cannot rise straight, metres.
RETREAT_BACK_OFFS = (0.0, 0.04, 0.08)
#: A retreat that draws back rises straight this far first, metres: the open fingers still
#: reach down beside what they let go of (they hold its top 1.5 cm; their tips are 1 cm
#: below the TCP), and drawing back at once, the far finger dragged a bowl along the rack
#: and lifted it away with the hand.
RETREAT_CLEAR_RISE = 0.03


@dataclass(frozen=True)
class PlanConfig:
    approach: float = 0.06  # pregrasp height above grasp and place, metres
    retreat: float = 0.12  # rise after release, metres: lifts the forearm clear of the stack
    lift: float = 0.08  # lift above the grasp before transfer, metres
    min_carry_z: float = 0.12  # lowest TCP height for moves across the table, metres
    #: Highest: a hand above this (the rest pose) comes down to it before moving across, as
    #: far reaches high up have no top-down solution. Clears a 6-block stack with a block held.
    max_carry_z: float = 0.30
    release_clearance: float = 0.003  # release this high above the goal, metres
    speed: float = 0.5  # peak Cartesian speed across the table, m/s
    slow_speed: float = 0.2  # peak speed of approach, grasp, place and lift, m/s
    joint_speed_fraction: float = 0.5  # of each joint's URDF velocity limit
    grip_time: float = 0.25  # seconds the arm holds still while the gripper moves
    sample_spacing: float = 0.01  # metres between IK samples along a line
    #: Hand yaw for a square object: at pi/2 the fingers close along the base x axis, so
    #: they never reach into a neighbour of a row along y (pyramid rows, box grids).
    hand_yaw: float = np.pi / 2

    def __post_init__(self) -> None:
        for name in (
            "approach",
            "retreat",
            "lift",
            "speed",
            "slow_speed",
            "grip_time",
            "sample_spacing",
        ):
            if getattr(self, name) <= 0:
                raise ConfigError(f"plan.{name}", "must be > 0")
        if not 0 < self.joint_speed_fraction <= 1:
            raise ConfigError("plan.joint_speed_fraction", "must be in (0, 1]")


def grasp_yaw(quaternion_xyzw: tuple[float, float, float, float]) -> float:
    """The object's yaw folded into [-45, 45] degrees: a cube looks the same every 90."""
    x, y, z, w = quaternion_xyzw
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return float((yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)


def turn_ways(start_yaw: float, yaw: float) -> tuple[float, float]:
    """``yaw`` as the end of a turn from ``start_yaw``: the short way round first, then the
    long way (the same pose; the wrist's joint limit may allow only one of them).

    Yaws are angles: a hand picked at yaw pi - 0.01 reads back as -pi + 0.01, and turning
    from there to pi/2 "directly" spins the wrist 270 degrees into its joint limit
    (``no_ik_solution`` across the table, where a quarter turn back was all it took)."""
    short = wrapped(yaw - start_yaw)
    long = short - 2 * np.pi if short > 0 else short + 2 * np.pi
    return start_yaw + short, start_yaw + long


class GraspPlanner:
    """Plans pick and place trajectories for the Panda from its current joint state."""

    def __init__(
        self,
        model: PandaModel,
        config: PlanConfig | None = None,
        elbow_push: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        """``elbow_push``: every IK solution also swings the elbow that way (``IKSolver``)."""
        self.model = model
        self.ik = IKSolver(model, elbow_push=elbow_push)
        self.config = config or PlanConfig()
        self.joint_speed = model.velocity_limit * self.config.joint_speed_fraction

    def pick(
        self, q: np.ndarray, position: np.ndarray, yaw: float = 0.0, carry_z: float = 0.0
    ) -> JointTrajectory:
        """From ``q``: pregrasp, grasp at ``position``, close, lift; moves across the table
        at least ``carry_z`` high."""
        c = self.config
        position = np.asarray(position, dtype=float)
        trajectory = JointTrajectory()
        trajectory.add(0.0, q, closed=False)
        pregrasp = position + c.approach * UP
        self._transit(trajectory, pregrasp, yaw, closed=False, what="pregrasp", carry_z=carry_z)
        self.line(trajectory, position, yaw, False, c.slow_speed, "grasp")
        trajectory.hold(c.grip_time, closed=True)
        self.line(trajectory, position + c.lift * UP, yaw, True, c.slow_speed, "lift")
        return trajectory

    def place(
        self, q: np.ndarray, position: np.ndarray, yaw: float = 0.0, carry_z: float = 0.0
    ) -> JointTrajectory:
        """From ``q`` (holding): transfer above ``position``, lower the object onto it. The
        transfer carries the hand at least ``carry_z`` high (e.g. so a wide object clears
        what it passes over)."""
        c = self.config
        position = np.asarray(position, dtype=float) + c.release_clearance * UP
        trajectory = JointTrajectory()
        trajectory.add(0.0, q, closed=True)
        above = position + c.approach * UP
        self._transit(trajectory, above, yaw, closed=True, what="transfer", carry_z=carry_z)
        self.line(trajectory, position, yaw, True, c.slow_speed, "place")
        return trajectory

    def slide(
        self, q: np.ndarray, grip: np.ndarray, shift: np.ndarray, yaw: float = 0.0
    ) -> JointTrajectory:
        """From ``q``: down onto ``grip`` (a handle) as to a grasp, close, then move the hand
        straight by ``shift`` holding on (a rack along its rail)."""
        c = self.config
        grip = np.asarray(grip, dtype=float)
        trajectory = JointTrajectory()
        trajectory.add(0.0, q, closed=False)
        self._transit(trajectory, grip + c.approach * UP, yaw, closed=False, what="pregrasp")
        self.line(trajectory, grip, yaw, False, c.slow_speed, "grasp")
        trajectory.hold(c.grip_time, closed=True)
        self.line(trajectory, grip + np.asarray(shift), yaw, True, c.slow_speed, "slide")
        return trajectory

    def release(self, q: np.ndarray, back: float = 0.0) -> JointTrajectory:
        """Open the gripper where the hand is, then retreat straight up (and ``back``
        metres towards the robot, -x: away from a handle, so the next move does not come
        down onto it)."""
        c = self.config
        trajectory = JointTrajectory()
        trajectory.add(0.0, q, closed=True)
        trajectory.hold(c.grip_time, closed=False)
        hand = self.model.tcp_pose(q).translation
        # Up by ``retreat``, but not above the carry ceiling (out of reach far out), and
        # never less than ``approach``.
        top = max(hand[2] + c.approach, min(hand[2] + c.retreat, c.max_carry_z))
        # Far out and high (a slot of a pulled-out rack) the arm may have no straight rise
        # without flipping: then, clear of what it let go of, it rises drawing back towards
        # the robot (where even that cannot rise straight, it draws back at once).
        rise = min(RETREAT_CLEAR_RISE, top - hand[2])
        ways = [(back + extra, rise if back + extra > 0 else 0.0) for extra in RETREAT_BACK_OFFS]
        ways += [(back + extra, 0.0) for extra in RETREAT_BACK_OFFS if back + extra > 0]
        for number, (away, first) in enumerate(ways, 1):
            attempt = copy.deepcopy(trajectory)
            try:
                if first > 0:
                    self.line(
                        attempt, hand + first * UP, self.yaw_of(q), False, c.slow_speed, "retreat"
                    )
                above = np.array([hand[0] - away, hand[1], top])
                self.line(attempt, above, self.yaw_of(q), False, c.slow_speed, "retreat")
            except SkillError:
                if number == len(ways):
                    raise
                continue
            return attempt
        return trajectory

    def home(self, q: np.ndarray, rise: float = 0.08) -> JointTrajectory:
        """From ``q`` (hand empty): straight up by ``rise`` (as far as IK allows), then to the
        home pose in joint space. For an arm left where no straight line leads on (a wrist
        near its limit after turning a dish over): every motion plans well from home."""
        c = self.config
        trajectory = JointTrajectory()
        trajectory.add(0.0, q, closed=False)
        pose = self.model.tcp_pose(q)
        with contextlib.suppress(SkillError):  # no straight rise from here: straight home
            up = pin.SE3(pose.rotation, pose.translation + rise * UP)
            self.pose_line(trajectory, up, False, c.slow_speed, "rise")
        start = trajectory.final
        path = start + np.linspace(0.0, 1.0, HOMING_SAMPLES)[:, None] * (HOME_Q - start)
        trajectory.add_segment(path, False, 0.0, c.speed, self.joint_speed)
        return trajectory

    # --- segments -------------------------------------------------------------------------
    def _transit(
        self,
        trajectory: JointTrajectory,
        target: np.ndarray,
        yaw: float,
        closed: bool,
        what: str,
        carry_z: float = 0.0,
    ) -> None:
        """To a height clear of both ends (and at least ``carry_z``), across, then down to
        ``target``."""
        start = self.model.tcp_pose(trajectory.final).translation
        start_yaw = self.yaw_of(trajectory.final)
        c = self.config
        carry = max(c.min_carry_z, min(start[2], c.max_carry_z), target[2], carry_z)
        speed = self.config.speed
        self.line(trajectory, [*start[:2], carry], start_yaw, closed, speed, f"{what} carry height")
        across = [*target[:2], carry]
        turns = turn_ways(start_yaw, yaw)
        for index, end_yaw in enumerate(turns):
            try:
                self.line(trajectory, across, end_yaw, closed, speed, what, start_yaw)
            except SkillError:
                if index == len(turns) - 1:
                    raise
                continue  # a failed line adds nothing: try the other way round
            break
        self.line(trajectory, target, end_yaw, closed, speed, what)

    def line(
        self,
        trajectory: JointTrajectory,
        end: np.ndarray | list[float],
        yaw: float,
        closed: bool,
        speed: float,
        what: str,
        start_yaw: float | None = None,
    ) -> None:
        """A straight TCP line from the trajectory's last point to ``end``; the yaw turns
        from ``start_yaw`` (default: ``yaw``) to ``yaw`` along the way."""
        q = trajectory.final
        start = self.model.tcp_pose(q).translation
        end = np.asarray(end, dtype=float)
        length = float(np.linalg.norm(end - start))
        first_yaw = yaw if start_yaw is None else start_yaw
        if length < 1e-4 and abs(first_yaw - yaw) < 1e-4:
            return
        count = max(1, int(np.ceil(length / self.config.sample_spacing)))
        path = [q]
        for s in np.arange(1, count + 1) / count:
            pose = top_down(start + s * (end - start), first_yaw + s * (yaw - first_yaw))
            path.append(self._follow(pose, path[-1], what))
        trajectory.add_segment(np.array(path), closed, length, speed, self.joint_speed)

    def pose_line(
        self,
        trajectory: JointTrajectory,
        end: pin.SE3,
        closed: bool,
        speed: float,
        what: str,
    ) -> None:
        """A straight TCP line from the trajectory's last point to the pose ``end``, the hand
        turning about one fixed axis on the way (the geodesic between the two rotations):
        the moves of the turn-over manoeuvre, where the hand is not top-down."""
        q = trajectory.final
        start = self.model.tcp_pose(q)
        length = float(np.linalg.norm(end.translation - start.translation))
        turn = pin.log3(start.rotation.T @ end.rotation)
        angle = float(np.linalg.norm(turn))
        if length < 1e-4 and angle < 1e-4:
            return
        count = max(
            1,
            int(np.ceil(length / self.config.sample_spacing)),
            int(np.ceil(angle / ANGLE_SPACING)),
        )
        path = [q]
        for s in np.arange(1, count + 1) / count:
            rotation = start.rotation @ pin.exp3(s * turn)
            position = start.translation + s * (end.translation - start.translation)
            pose = pin.SE3(rotation, position)
            path.append(self._follow(pose, path[-1], what))
        # A turn in place is timed by the joints' speeds alone.
        trajectory.add_segment(np.array(path), closed, length, speed, self.joint_speed)

    def _follow(self, pose: pin.SE3, previous: np.ndarray, what: str) -> np.ndarray:
        """IK for the next sample along a line, from the previous one; ``no_ik_solution``
        if the descent found the pose only in another arm configuration (a joint clamped
        at its limit, say): the arm would swing through the workspace between samples."""
        q = self.ik.solve_or_raise(pose, previous, what, restart=False)
        if float(np.max(np.abs(q - previous))) > MAX_JOINT_STEP:
            raise SkillError("no_ik_solution", f"{what}: the arm would flip between samples")
        return q

    def yaw_of(self, q: np.ndarray) -> float:
        rotation = self.model.tcp_pose(q).rotation
        return float(np.arctan2(rotation[1, 0], rotation[0, 0]))
