"""A Panda motion driver's plans that clear the arm: each motion checked for arm links that
would touch the table or an obstacle of the grasp, and re-planned around them (the hand
turned, the elbow swung aside, carried higher or low) before anything is sent to the robot.
A motion that no re-plan clears is refused as ``collision``."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_skills.drivers.base import Grasp
from manigraph_skills.motion import GraspPlanner, JointTrajectory, PandaModel
from manigraph_skills.motion.collision import ArmCollisionModel, Contact, refusal
from manigraph_skills.motion.model import wrapped
from manigraph_skills.obstacles import Obstacle

log = logging.getLogger("manigraph.skills.motion")

#: After the planned motion collides: the carry height as chosen, then the hand's own
#: height if it is above the planner's ceiling, then the ceiling (``PlanConfig.max_carry_z``);
#: at each, the arm as planned and with its elbow swung to either side of the target's bearing
#: (``ELBOW_SWING``), each with the hand as chosen and turned a quarter (a block or a square
#: cover is held the same either way).
QUARTER = np.pi / 2
#: The last carry height tried, metres: the hand (10 cm above the TCP) under a pulled-out
#: top rack's floor and handle (0.30 m), the fingertips over a pulled-out bottom rack's floor
#: (0.125 m) and the dishes on the counter. Carried at the ceiling (0.30 m), or at 0.20 m,
#: the hand reaching for a dish of the counter's far row met the top rack's front edge or
#: its handle on every re-plan.
LOW_CARRY_Z = 0.15
#: Gains of the null-space elbow swing (``IKSolver.elbow_push``), gentle first: it acts at
#: every IK sample along the motion, so it adds up over a long one (at 0.05 the elbow of a
#: far, low grasp from the home pose swings ~0.3 m aside) but not over a short one (from
#: above a tower to a block beside it only 0.3 cleared the tower).
ELBOW_SWING = (0.05, 0.3)
#: The fingers are alike: a hand turned half round about the vertical holds what it holds
#: the same way, and every object here (blocks, covers, plates, bowls) is square. Its wrist
#: joint is then half a turn from where it was: a far corner of the counter that the wrist
#: could not turn to (``no_ik_solution``, at its joint limit) is reached turned half round,
#: and the forearm passes a neighbour on the other side.
HALF_TURN = np.pi


class Replanner:
    """Plans for ``model`` by ``planner`` checked against ``collision`` (None: unchecked);
    ``raise_if_stopped`` is called between re-plans (each takes 50-500 ms), so an emergency
    stop or an ended episode cuts a long search short."""

    def __init__(
        self,
        model: PandaModel,
        planner: GraspPlanner,
        collision: ArmCollisionModel | None,
        raise_if_stopped: Callable[[], None],
    ) -> None:
        self.model = model
        self.planner = planner
        self.collision = collision
        self.raise_if_stopped = raise_if_stopped

    def avoiding(
        self,
        make: Callable[[GraspPlanner, np.ndarray, float, float], JointTrajectory],
        grasp: Grasp,
        target: np.ndarray,
        motion: str,
    ) -> Callable[[np.ndarray], JointTrajectory]:
        """``make(planner, q, turn, carry_z)`` as planned; if an arm link would touch
        something, re-planned with the hand turned, the elbow swung aside and higher, and
        last carried low (``LOW_CARRY_Z``), until one is clear. Last of all, the same with the
        hand turned half round (``HALF_TURN``). ``motion`` names it in the refusal ("taking
        it: panda_hand would touch ...")."""
        bearing = float(np.arctan2(target[1], target[0]))
        aside = np.array([-np.sin(bearing), np.cos(bearing), 0.0])
        pushes = [tuple(gain * side * aside) for gain in ELBOW_SWING for side in (1.0, -1.0)]
        planners = [self.planner] + [
            GraspPlanner(self.model, self.planner.config, elbow_push=push) for push in pushes
        ]
        low = replace(self.planner.config, max_carry_z=LOW_CARRY_Z)
        low_planners = [GraspPlanner(self.model, low)] + [
            GraspPlanner(self.model, low, elbow_push=push) for push in pushes
        ]

        turns = (0.0, grasp.other_turn)
        flipped = (HALF_TURN, grasp.other_turn + HALF_TURN)
        half_turned = tuple(t for t in flipped if not _same_yaw(t, turns))

        def plan(q: np.ndarray) -> JointTrajectory:
            heights = self.carry_heights(q, grasp.carry_z)
            options = []
            # The hand as chosen (and at its other yaw) first; then turned half round.
            for yaws in (turns, half_turned):
                options += [
                    (planner, turn, carry)
                    for carry in heights
                    for planner in planners
                    for turn in yaws
                ]
                if grasp.carry_z < LOW_CARRY_Z:
                    options += [
                        (planner, turn, grasp.carry_z) for planner in low_planners for turn in yaws
                    ]
            contacts: dict[tuple[str, str], Contact] = {}
            failure: SkillError | None = None
            for planner, turn, carry in options:
                self.raise_if_stopped()  # a re-plan takes 50-500 ms: stop between them
                try:
                    trajectory = make(planner, q, turn, carry)
                except SkillError as exc:  # e.g. no IK solution this high or turned
                    failure = failure or exc
                    continue
                trajectory.opening = grasp.opening
                found = self.contact(trajectory, grasp.obstacles)
                if found is None:
                    if contacts:
                        log.info(
                            "re-planned around %s: carry %.2f m, turn %.2f, elbow %s",
                            next(iter(contacts.values())),
                            carry,
                            turn,
                            "as planned" if planner is self.planner else "swung aside",
                        )
                    return trajectory
                contacts.setdefault((found.link, found.obstacle), found)
            if contacts:
                raise SkillError("collision", f"{motion}: {refusal(contacts)}")
            assert failure is not None
            raise failure

        return plan

    def carry_heights(self, q: np.ndarray, carry_z: float) -> list[float]:
        """The carry heights to plan at, in turn: as chosen; the hand's own height, if it is
        above the planner's ceiling (``PlanConfig.max_carry_z``); the ceiling.

        A hand above the ceiling first comes down to it where it is, before moving across.
        After setting a block on a tower taller than the ceiling (K = 9: its top at 0.36 m)
        the hand retreats above it, and coming down there would put the fingers into the
        tower's top block, on every re-plan at or under the ceiling; moving across at the
        hand's own height first does not; nor, just out of a rack's slot, into the dish in it."""
        ceiling = self.planner.config.max_carry_z
        hand = float(self.model.tcp_pose(q).translation[2])
        heights = [carry_z]
        if hand > max(ceiling, carry_z):
            heights.append(hand)
        if ceiling > carry_z:
            heights.append(ceiling)
        return heights

    def checked(
        self,
        make: Callable[[np.ndarray], JointTrajectory],
        obstacles: tuple[Obstacle, ...],
        opening: float | None = None,
    ) -> Callable[[np.ndarray], JointTrajectory]:
        """``make``, the fingers open ``opening`` apart (None: fully), refused as ``collision``
        if an arm link would touch something."""

        def plan(q: np.ndarray) -> JointTrajectory:
            trajectory = make(q)
            trajectory.opening = opening
            found = self.contact(trajectory, obstacles)
            if found is not None:
                raise SkillError("collision", str(found))
            return trajectory

        return plan

    def contact(
        self, trajectory: JointTrajectory, obstacles: tuple[Obstacle, ...]
    ) -> Contact | None:
        if self.collision is None:
            return None
        return self.collision.first_contact(trajectory, obstacles)


def _same_yaw(turn: float, turns: tuple[float, ...]) -> bool:
    """Whether ``turn`` is one of ``turns`` as an angle (a plate's other yaw is already half a
    turn)."""
    return any(abs(wrapped(turn - other)) < 1e-6 for other in turns)
