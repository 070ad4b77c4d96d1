"""A Panda driver that plans its own motion: Pinocchio IK on the skill side, joint
trajectories to the robot. The robot end (sim or hardware) is a ``JointTransport``
(``joint_transport``); the plans that clear the arm are ``replanning``'s. This module
executes them: one decision's motions, their checks, stops and the end of its episode.

Checks, each reported as a ``SkillError`` reason:

* ``no_ik_solution``: a waypoint cannot be reached (nothing is sent to the robot);
* ``collision``: an arm link would touch the table or an obstacle of the grasp
  (``Grasp.obstacles``) on every re-plan: higher across the table and the hand turned a
  quarter (``motion.collision``); nothing is sent to the robot;
* ``grasp_slipped``: after closing and lifting (or after the transfer) the fingers closed to
  less than ``min_grasp_width``, so nothing is between them;
* ``placement_missed``: after release the object's centre is more than
  ``placement_tolerance`` from the target (when the transport can observe objects);
* ``orientation_unreachable``: a placement asks for another up axis than the object has and
  the fingers span it across no axis that would tilt it there (its family's turn-over: the
  turn-over manoeuvre tilts it on the counter first, then the top-down grasp places it);
* ``handle_missed``: the fingers closed on nothing at a rack's handle; ``rack_stuck``: after a
  toggle the scene still shows the rack where it was;
* ``episode_ended``: the world ended the decision's episode while it ran
  (:meth:`PandaMotionDriver.end_decision`); nothing more is sent for it.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import (
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    JointTrajectoryResult,
    Quaternion,
    Scene,
    SceneObject,
)
from manigraph_shared.orientations import postures_like, up_axis_orientation
from manigraph_skills.drivers.base import (
    PLANNING_FAILURES,
    Grasp,
    Motion,
    RobotDriver,
    TrayToggle,
)
from manigraph_skills.drivers.joint_transport import JointTransport
from manigraph_skills.drivers.registry import MotionOptions
from manigraph_skills.drivers.replanning import Replanner
from manigraph_skills.family import family_of
from manigraph_skills.motion import (
    HOME_Q,
    GraspPlanner,
    JointTrajectory,
    PandaModel,
    PlanConfig,
)
from manigraph_skills.motion.collision import ArmCollisionModel
from manigraph_skills.motion.plan import UP, grasp_yaw
from manigraph_skills.obstacles import Obstacle

log = logging.getLogger("manigraph.skills.motion")

#: Planning failures that going home first may cure (the hand is empty).
HOMING_HELPS = ("no_ik_solution", "collision")
#: After letting go of a rack's handle the hand rises and backs off this far towards the
#: robot, metres, clear of the handle and the rack.
HANDLE_BACK_OFF = 0.1


class PandaMotionDriver(RobotDriver):
    name = "panda-motion"
    checks_family_rules = True

    def __init__(
        self,
        transport: JointTransport,
        options: MotionOptions | None = None,
        config: PlanConfig | None = None,
        check_collisions: bool = True,
    ) -> None:
        options = options or MotionOptions()
        self.transport = transport
        self.model = PandaModel()
        self.planner = GraspPlanner(self.model, config)
        self.collision = ArmCollisionModel(self.model) if check_collisions else None
        self.plans = Replanner(self.model, self.planner, self.collision, self.raise_if_stopped)
        self.min_grasp_width = options.min_grasp_width
        self.placement_tolerance = options.placement_tolerance
        self._ids = itertools.count()
        self._stopped = False
        #: Emergency stops so far, and how many there had been when the decision whose
        #: motions are being planned began: a decision stopped (and resumed) while it was
        #: planning never moves the arm afterwards.
        self._stops = 0
        #: (decision, reason) whose episode the world ended (``end_decision``).
        self._ended: tuple[str, str] | None = None
        self._decision: str | None = None
        self._decision_stops = 0
        #: The object last picked: its id, the hand's position and yaw, the grasp.
        self._picked: tuple[str, np.ndarray, float, Grasp] | None = None

    def pick(self, motion: Motion) -> None:
        grasp, orientation = motion.grasp, motion.orientation
        target = np.array(motion.position.as_tuple()) + grasp.height * UP
        yaw = (
            self.planner.config.hand_yaw
            + grasp.turn
            + grasp_yaw((orientation.x, orientation.y, orientation.z, orientation.w))
        )
        self.pick_at(motion.decision_id, motion.object_id, target, yaw, grasp)

    def pick_at(
        self, decision_id: str, object_id: str, target: np.ndarray, yaw: float, grasp: Grasp
    ) -> None:
        """Take ``object_id`` top-down with the TCP at ``target`` and the hand at ``yaw`` (or
        turned by ``grasp.other_turn`` if that is what clears the arm), and lift it."""
        self._picked = None
        result = self.run_plan(
            decision_id,
            self.plans.avoiding(
                lambda planner, q, turn, carry: planner.pick(q, target, yaw + turn, carry),
                grasp,
                target,
                "taking it",
            ),
            home_around=grasp.obstacles,
        )
        # The yaw the hand took (``plans.avoiding`` may have turned it): put back with it.
        taken = self.planner.yaw_of(np.array(result.positions)) if result.positions else yaw
        self._picked = (object_id, target, taken, grasp)
        if result.gripper_width < self.min_grasp_width:
            self.release(decision_id, grasp)
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
        try:
            carry = self.run_plan(
                decision_id,
                self.plans.avoiding(
                    lambda planner, q, turn, carry_z: planner.place(q, hand, yaw + turn, carry_z),
                    grasp,
                    hand,
                    "carrying it to its goal",
                ),
            )
        except SkillError as exc:
            if exc.reason in PLANNING_FAILURES:
                self.put_back(decision_id, object_id)
            raise
        if carry.gripper_width < self.min_grasp_width:
            self.release(decision_id, grasp)
            raise SkillError("grasp_slipped", f"{object_id} was lost during the transfer")
        released = self.release(decision_id, grasp)
        seen = self.transport.object_position(object_id, after=released.stamp)
        if seen is not None:
            miss = float(np.linalg.norm(seen - target))
            if miss > self.placement_tolerance:
                raise SkillError(
                    "placement_missed", f"{object_id} rests {miss * 1000:.0f} mm from its goal"
                )

    def put_back(self, decision_id: str, object_id: str) -> None:
        """After a place that could not be planned: set the held object down where it was
        picked, as it was held, so a refused placement leaves it where it was (best effort:
        if that cannot be planned either, it stays held)."""
        if self._picked is None or self._picked[0] != object_id:
            return
        _, hand, yaw, grasp = self._picked
        self._picked = None
        try:
            self.run_plan(
                decision_id,
                self.plans.checked(
                    lambda q: self.planner.place(q, hand, yaw), grasp.obstacles, grasp.opening
                ),
            )
            self.release(decision_id, grasp)
        except SkillError as exc:
            log.info("could not put %s back: %s", object_id, exc)

    def check_orientation(self, object_id: str, current: Quaternion, target: Quaternion) -> None:
        """An object whose up axis must change is tilted first (:meth:`turn_over`): refused
        only if the fingers span it across no axis that would turn it there (its size is
        checked by :meth:`turn_over` itself, which has the scene)."""

    def turn_over(
        self, decision_id: str, item: SceneObject, target: Quaternion, scene: Scene
    ) -> SceneObject:
        """Tilt ``item`` on the counter until it stands as ``target`` asks, by the turn-over
        manoeuvre of the scene's family (``SkillFamily.turn_over``, composed of this driver's
        public pieces): its up axis ``target``'s, or for a plate on its rim any edge down
        (``orientations.postures_like``); the object as it then lies."""
        wanted = postures_like(item.category.value, up_axis_orientation(target))
        if up_axis_orientation(item.orientation) in wanted:
            return item
        family = family_of(scene)
        manoeuvre = family.part("turn_over")
        if manoeuvre is None:
            raise SkillError(
                "orientation_unreachable", f"the {family.name} family has no turn-over manoeuvre"
            )
        turned: SceneObject = manoeuvre(self, decision_id, item, wanted, scene)
        return turned

    def toggle_tray(self, toggle: TrayToggle) -> None:
        """Down onto the rack's handle tab (``toggle.grip`` from its handle), close across it,
        pull the rack out along -x (or push it in) as far as it has left to go, release and
        rise."""
        decision_id, rack_id, is_open = toggle.decision_id, toggle.rack_id, toggle.is_open
        start = np.array(toggle.handle.as_tuple())
        grip = start + np.array(toggle.grip)
        rail = toggle.rail
        out = (rail if is_open else 0.0) if toggle.travel is None else toggle.travel
        distance = out if is_open else rail - out
        shift = np.array([distance if is_open else -distance, 0.0, 0.0])
        # Yaw 0: the fingers close along y, across the tab.
        held = self.run_plan(
            decision_id,
            self.plans.checked(lambda q: self.planner.slide(q, grip, shift, 0.0), ()),
            home_around=(),
        )
        if held.gripper_width < self.min_grasp_width:
            self.release(decision_id, Grasp())
            raise SkillError(
                "handle_missed", f"fingers closed to {held.gripper_width * 1000:.1f} mm"
            )
        released = self.run_plan(
            decision_id, self.plans.checked(lambda q: self.planner.release(q, HANDLE_BACK_OFF), ())
        )
        seen = self.transport.object_position(rack_id, after=released.stamp)
        if seen is not None and abs(seen[0] - start[0]) < distance / 2:
            raise SkillError("rack_stuck", f"{rack_id} is still where it was")

    def stop(self) -> None:
        self._stopped = True
        self._stops += 1
        self.transport.stop()

    def resume(self) -> None:
        self._stopped = False
        self.transport.resume()

    def abort(self, reason: str) -> None:
        self.transport.abort(reason)

    def begin_decision(self, decision_id: str) -> None:
        self._decision, self._decision_stops, self._ended = decision_id, self._stops, None

    def end_decision(self, decision_id: str, reason: str) -> None:
        """Safe from any thread. A world that ends an episode during its last motion (the
        goals filled as a rack passed half its rail) and resets at once answers the rest
        ``start_mismatch``; re-planned from the new episode's home pose, that motion ran in
        the next episode's world, and its first pull of the top rack came to nothing."""
        self._ended = (decision_id, reason)
        if self._decision == decision_id:
            self.transport.abort(reason)

    # --- pieces: what a skill extension composes its motions from (a family's turn-over)
    def release(self, decision_id: str, grasp: Grasp) -> JointTrajectoryResult:
        """Open as wide as ``grasp`` says where the hand is and retreat (after a placement,
        or after a lost grasp, so the next attempt starts clean)."""
        return self.run_plan(
            decision_id, self.plans.checked(self.planner.release, grasp.obstacles, grasp.opening)
        )

    def run_plan(
        self,
        decision_id: str,
        plan: Callable[[np.ndarray], JointTrajectory],
        home_around: tuple[Obstacle, ...] | None = None,
    ) -> JointTrajectoryResult:
        """Plan from the arm's joints and execute; plan once more if the arm was elsewhere.
        With ``home_around`` (the hand is empty): if nothing can be planned from where the
        arm is (no IK solution, or every plan touches something: a hand left over a pulled-out
        rack comes down onto its floor on its way out), it goes home first
        (``GraspPlanner.home``, checked against those obstacles) and plans from there."""
        if decision_id != self._decision:
            self._decision, self._decision_stops = decision_id, self._stops
        self.raise_if_stopped()
        q = self.transport.joint_positions()
        if home_around is not None:
            plan = self._homing_first(decision_id, plan, home_around)
        for _attempt in range(2):
            trajectory = plan(q)  # raises SkillError('no_ik_solution') before any motion
            self.raise_if_stopped()  # the stop (and maybe resume) came while planning
            result = self.transport.execute(self._command(decision_id, trajectory))
            if result.ok:
                return result
            if result.reason != "start_mismatch":
                raise SkillError(result.reason or "driver_error", result.detail)
            q = np.array(result.positions)
        raise SkillError("start_mismatch", "the arm keeps moving away from the planned start")

    def _homing_first(
        self,
        decision_id: str,
        plan: Callable[[np.ndarray], JointTrajectory],
        obstacles: tuple[Obstacle, ...],
    ) -> Callable[[np.ndarray], JointTrajectory]:
        def from_home_if_stuck(q: np.ndarray) -> JointTrajectory:
            try:
                return plan(q)
            except SkillError as exc:
                if exc.reason not in HOMING_HELPS or np.allclose(q, HOME_Q, atol=0.05):
                    raise
                homing = self.planner.home(q)
                if self.plans.contact(homing, obstacles) is not None:
                    raise
                log.info("going home first: %s", exc.detail)
                result = self.transport.execute(self._command(decision_id, homing))
                if not result.ok:
                    raise
                return plan(np.array(result.positions))

        return from_home_if_stuck

    def raise_if_stopped(self) -> None:
        if self._stopped:
            raise SkillError("stopped", "emergency stop engaged")
        if self._stops != self._decision_stops:
            raise SkillError("stopped", "an emergency stop came during this decision")
        ended = self._ended
        if ended is not None and ended[0] == self._decision:
            raise SkillError(ended[1], f"the episode of {self._decision} has ended")

    def _command(self, decision_id: str, trajectory: JointTrajectory) -> JointTrajectoryCommand:
        return JointTrajectoryCommand(
            command_id=derived_id(decision_id, ".", str(next(self._ids))),
            decision_id=decision_id,
            joint_names=list(self.model.joint_names),
            points=[
                JointTrajectoryPoint(
                    positions=q.tolist(),
                    gripper=GripperTarget.CLOSED if closed else GripperTarget.OPEN,
                    opening=trajectory.opening,
                    time_from_start=t,
                )
                for t, q, closed in zip(
                    trajectory.times, trajectory.positions, trajectory.closed, strict=True
                )
            ],
            stamp=time.time(),
        )
