"""``franka``: the Franka Panda on real hardware, through franky (libfranka + Ruckig).

The same :class:`PandaMotionDriver` as ``panda-sim`` plans every pick, place and release with
Pinocchio; only the transport differs. :class:`FrankaJointTransport` checks each trajectory
against the Panda's limits and the workspace (``franka_limits``), then runs it on the arm as
franky joint waypoint motions, pausing for the hand where the gripper target changes.

* ``--dry-run`` plans and validates exactly the same trajectories, publishes each as a
  ``JointTrajectoryCommand`` on the bus (so it lands in the MCAP log) with a log line, and
  moves nothing. With an address it reads the robot's joints once to plan from them.
* No robot at the address: start-up fails with a ``ConfigError`` naming the address within
  ``connect_timeout`` (libfranka alone waits 60 s).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.messages import (
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    JointTrajectoryResult,
    Scene,
)
from manigraph_shared.panda import FINGER_OPEN
from manigraph_skills.drivers.franka_config import FrankaConfig
from manigraph_skills.drivers.franka_limits import TrajectoryLimits
from manigraph_skills.drivers.joint_transport import object_seen_after
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.motion import HOME_Q, PandaModel

log = logging.getLogger("manigraph.skills.franka")

#: Both fingers fully open, metres between them.
OPEN_WIDTH = 2 * FINGER_OPEN


def _franky() -> Any:
    import franky  # a ~13 MB native library: loaded only when the driver is used

    return franky


def connect(
    config: FrankaConfig,
    robot_class: Callable[..., Any] | None = None,
    gripper_class: Callable[..., Any] | None = None,
) -> tuple[Any, Any | None]:
    """The robot (and its hand) at ``config.address``; a ``ConfigError`` naming the address
    if nothing answers within ``config.connect_timeout`` seconds."""
    franky = _franky()
    robot_class = robot_class or franky.Robot
    gripper_class = gripper_class or franky.Gripper
    realtime = franky.RealtimeConfig.Enforce if config.realtime else franky.RealtimeConfig.Ignore

    def open_robot() -> Any:
        robot = robot_class(config.address, realtime_config=realtime)
        robot.relative_dynamics_factor = config.speed_factor
        robot.set_collision_behavior(config.contact_torque, config.contact_force)
        return robot

    robot = _within(config, "robot", open_robot)
    gripper = _within(config, "gripper", lambda: gripper_class(config.address))
    return robot, gripper if config.gripper else None


def _within(config: FrankaConfig, what: str, opener: Callable[[], Any]) -> Any:
    """``opener()`` on a helper thread, given up after ``connect_timeout`` seconds."""
    outcome: dict[str, Any] = {}

    def attempt() -> None:
        try:
            outcome["value"] = opener()
        except Exception as exc:  # the library's own exception types: reported below
            outcome["error"] = exc

    worker = threading.Thread(target=attempt, name=f"franka-connect-{what}", daemon=True)
    worker.start()
    worker.join(config.connect_timeout)
    where = f"no Franka {what} answers at {config.address}"
    if worker.is_alive():
        raise ConfigError("franka.address", f"{where} within {config.connect_timeout:g} s")
    if "error" in outcome:
        error = outcome["error"]
        if type(error).__name__ == "RealtimeException":
            raise ConfigError(
                "franka.realtime",
                f"{error}; run on a PREEMPT_RT kernel (MANIGRAPH_FRANKA_REALTIME=0 only for "
                "dry runs)",
            )
        raise ConfigError("franka.address", f"{where}: {error}")
    return outcome["value"]


class FrankaJointTransport:
    """Validated joint trajectories to a Franka arm via franky, or only to the log (dry run)."""

    def __init__(
        self,
        config: FrankaConfig,
        robot: Any | None,
        gripper: Any | None,
        bus: Bus | None = None,
        model: PandaModel | None = None,
    ) -> None:
        if robot is None and not config.dry_run:
            raise ConfigError("franka.address", "a robot is required unless dry_run")
        self.config = config
        self.robot = robot
        self.gripper = gripper
        self.bus = bus
        self.limits = TrajectoryLimits(
            model or PandaModel(), config.workspace, config.joint_margin, config.limit_fraction
        )
        #: Dry run: where the arm would be (it never moves); starts at the robot's joints.
        self._dry_q = self._read_joints() if robot is not None else HOME_Q.copy()
        self._dry_width = OPEN_WIDTH
        self._scene: Scene | None = None
        self._lock = threading.Condition()
        self._stopped = False
        #: Set by ``abort`` (the skills service lost what it depends on): the motion under way
        #: ends with this reason instead of its own result.
        self._aborted: str | None = None
        if bus is not None and not config.dry_run:
            bus.subscribe(Scene, self._on_scene)  # perception's scenes: placement checks

    # --- JointTransport -----------------------------------------------------------------------
    def stop(self) -> None:
        """Emergency stop: halt the arm now (best effort through franky) and refuse motions."""
        self._stopped = True
        self._halt()

    def resume(self) -> None:
        self._stopped = False

    def abort(self, reason: str) -> None:
        """Halt the motion under way, which then fails with ``reason``; later ones run."""
        self._aborted = reason
        self._halt()

    def _halt(self) -> None:
        if self.robot is not None and not self.config.dry_run:
            try:
                self.robot.stop()
            except Exception as exc:  # the library's; the flags still refuse what follows
                log.warning("stopping the robot: %s", exc)

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        if self._stopped:
            raise SkillError("stopped", "emergency stop engaged")
        slowdown = 1.0 / self.config.speed_factor
        report = self.limits.check(command, slowdown)  # raises before anything moves
        if not self.config.gripper and any(
            p.gripper is GripperTarget.CLOSED for p in command.points
        ):
            raise SkillError("no_gripper", "the trajectory closes a gripper; none is mounted")
        if self.config.dry_run:
            if self.bus is not None:
                self.bus.publish(command)
            log.info(
                "dry run %s: %d points, %.2f s at speed factor %g, peak %.0f%% of the velocity "
                "and %.0f%% of the acceleration limits, TCP within %s .. %s m: not moved",
                command.command_id,
                report.points,
                report.duration,
                self.config.speed_factor,
                100 * report.peak_velocity_ratio,
                100 * report.peak_acceleration_ratio,
                np.round(report.tcp_low, 3).tolist(),
                np.round(report.tcp_high, 3).tolist(),
            )
            self._dry_q = np.array(command.points[-1].positions)
            last = command.points[-1]
            closed = last.gripper is GripperTarget.CLOSED
            self._dry_width = self.config.grasp_width if closed else _opening(last)
            return self._result(command, self._dry_q, self._dry_width)
        start = self._read_joints()
        offset = np.abs(start - np.array(command.points[0].positions))
        if float(offset.max()) > self.config.start_tolerance:
            return self._result(
                command,
                start,
                self._width(),
                "start_mismatch",
                f"arm is {float(offset.max()):.3f} rad from the trajectory's start",
            )
        self._aborted = None
        try:
            self._run(command)
        except Exception as exc:  # franky's ControlException, GripperException, ...
            if isinstance(exc, SkillError):
                raise
            if self._aborted is not None:
                raise SkillError(self._aborted, "motion aborted") from exc
            return self._result(
                command, self._read_joints(), self._width(), "robot_error", str(exc)[:1000]
            )
        if self._aborted is not None:
            raise SkillError(self._aborted, "motion aborted")
        return self._result(command, self._read_joints(), self._width())

    def joint_positions(self) -> np.ndarray:
        if self.config.dry_run:
            return self._dry_q.copy()
        return self._read_joints()

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        if self.config.dry_run:
            return None  # nothing moved, so nothing can be where it was planned to go
        return object_seen_after(self._lock, lambda: self._scene, object_id, after)

    # --- pieces -------------------------------------------------------------------------------
    def _on_scene(self, scene: Scene) -> None:
        with self._lock:
            self._scene = scene
            self._lock.notify_all()

    def _read_joints(self) -> np.ndarray:
        assert self.robot is not None
        return np.array(self.robot.current_joint_positions, dtype=float).reshape(-1)

    def _width(self) -> float:
        if self.gripper is None:
            return OPEN_WIDTH
        return float(np.clip(self.gripper.width, 0.0, 0.2))

    def _run(self, command: JointTrajectoryCommand) -> None:
        """Arm motions between gripper changes (closing, or opening to another width); each
        change waits for the hand."""
        franky = _franky()
        points = command.points
        first = points[0]
        if first.gripper is GripperTarget.OPEN and abs(self._width() - _opening(first)) > 0.002:
            self._grip(first)  # open as wide as this motion wants before it moves
        gripper = (first.gripper, first.opening)
        run: list[int] = [0]
        for index in range(1, len(points)):
            if (points[index].gripper, points[index].opening) != gripper:
                self._move(franky, command, run)
                gripper = (points[index].gripper, points[index].opening)
                self._grip(points[index])
                run = [index - 1]
            run.append(index)
        self._move(franky, command, run)

    def _move(self, franky: Any, command: JointTrajectoryCommand, run: list[int]) -> None:
        """Follow the points ``run`` (the first is where the arm is) as franky waypoints, each
        reached no sooner than planned (slowed by ``speed_factor``), passing through with the
        planned velocity so the hand keeps to its straight lines."""
        q = np.array([command.points[i].positions for i in run])
        t = np.array([command.points[i].time_from_start for i in run]) / self.config.speed_factor
        if len(run) < 2 or float(np.abs(q[1:] - q[0]).max()) < 1e-6:
            return  # the arm holds still here (e.g. while the gripper moves)
        velocity = np.zeros_like(q)
        if len(run) > 2:
            velocity[1:-1] = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
        waypoints = [
            franky.JointWaypoint(
                franky.JointState(q[i], velocity[i]),
                minimum_time=franky.Duration(round(float(t[i] - t[i - 1]) * 1000)),
            )
            for i in range(1, len(run))
        ]
        self.robot.move(franky.JointWaypointMotion(waypoints))  # type: ignore[union-attr]

    def _grip(self, point: JointTrajectoryPoint) -> None:
        if self.gripper is None:
            raise SkillError("no_gripper", "no gripper is mounted")
        c = self.config
        if point.gripper is GripperTarget.CLOSED:
            # Anything from 0 to twice the expected width counts: the driver judges the
            # grasp from the width the fingers closed to.
            self.gripper.grasp(
                c.grasp_width, c.gripper_speed, c.grasp_force, c.grasp_width, c.grasp_width
            )
        else:
            self.gripper.move(_opening(point), c.gripper_speed)

    def _result(
        self,
        command: JointTrajectoryCommand,
        q: np.ndarray,
        width: float,
        reason: str | None = None,
        detail: str = "",
    ) -> JointTrajectoryResult:
        return JointTrajectoryResult(
            command_id=command.command_id,
            ok=reason is None,
            reason=reason,
            detail=detail,
            positions=np.asarray(q, dtype=float).tolist(),
            gripper_width=width,
            stamp=time.time(),
        )


class FrankaDriver(PandaMotionDriver):
    """The Panda motion driver on a real Franka (``MANIGRAPH_FRANKA_*`` configure it).
    Registered as ``franka`` (options: ``drivers.registry.FrankaOptions``)."""

    name = "franka"

    @classmethod
    def from_options(cls, bus: Any, options: Any) -> FrankaDriver:
        return cls(bus, dry_run=options.dry_run)

    def __init__(
        self,
        bus: Bus | None = None,
        config: FrankaConfig | None = None,
        dry_run: bool | None = None,
        robot_class: Callable[..., Any] | None = None,
        gripper_class: Callable[..., Any] | None = None,
    ) -> None:
        overrides = {} if dry_run is None else {"dry_run": dry_run}
        if config is None:
            config = FrankaConfig.from_env(os.environ, **overrides)
        elif overrides:
            config = FrankaConfig(**{**config.__dict__, **overrides})
        robot = gripper = None
        if config.address:
            robot, gripper = connect(config, robot_class, gripper_class)
        self.config = config
        super().__init__(FrankaJointTransport(config, robot, gripper, bus))
        log.info(
            "franka %s%s, speed factor %g",
            config.address or "(no robot)",
            " DRY RUN: nothing moves" if config.dry_run else "",
            config.speed_factor,
        )

    def close(self) -> None:
        robot = getattr(self.transport, "robot", None)
        if robot is not None and not self.config.dry_run:
            try:
                robot.stop()
            except Exception as exc:  # the library's; stopping is best effort on shutdown
                log.warning("stopping the robot: %s", exc)


def _opening(point: JointTrajectoryPoint) -> float:
    """How far apart the fingers open at ``point``, metres (fully, unless it says)."""
    return OPEN_WIDTH if point.opening is None else min(point.opening, OPEN_WIDTH)
