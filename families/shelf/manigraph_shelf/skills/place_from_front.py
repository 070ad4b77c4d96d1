"""PickAndPlace into a shelf slot: the shelf family's own action (``SkillFamily.takes``: an
action whose goal is a slot).

A driver that moves objects as it is told (the geometric world's gripper) takes and places the
block as in every other world. The Panda driver plans the shelf's own moves
(:mod:`.front_motion`): it chooses, before anything moves, a side grasp off the table (the
hand pitched as :data:`~.front_motion.PITCHES` says, approaching the block square to its
faces from the robot's side or either flank) for which the place into the slot from the front
also plans, both clear of the arm-collision check (the cupboard, the other blocks, the table).
Then: take it, check it is held, carry it in, let go and draw back out, and check where it
came to rest. A place that cannot be planned after the pick sets the block back down where it
was taken.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    Action,
    Quaternion,
    Scene,
    SceneObject,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_shelf.shelf_geometry import is_shelf_scene
from manigraph_shelf.skills.front_motion import (
    MAX_TILT,
    PICK_PITCHES,
    PLACE_PITCHES,
    Carry,
    Hand,
    approach_to,
    front_place,
    line,
    retreat,
    side_pick,
)
from manigraph_shelf.skills.obstacles import scene_geometry
from manigraph_skills.drivers.base import PLANNING_FAILURES, Motion
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.grasp_choice import choose_grasps
from manigraph_skills.motion import HOME_Q, JointTrajectory
from manigraph_skills.motion.collision import Contact, refusal
from manigraph_skills.motion.plan import grasp_yaw
from manigraph_skills.obstacles import Obstacle, scene_obstacles

if TYPE_CHECKING:
    from manigraph_skills.pick_and_place import PickAndPlace

log = logging.getLogger("manigraph.skills.shelf")

#: The fingers' opening around a 4 cm block, metres: 1.25 cm to spare on either side (slot
#: columns are 10 cm apart; fully open, 8 cm, they would reach a neighbour's face).
OPENING = 0.065
#: Their width while holding it, for the arm check of the moves that carry it.
HOLDING = 0.04
#: Where a block that cannot be taken from its side where it lies is first set down
#: top-down (x and y of the spots, metres, nearest the slot's column first): on the table
#: between the start cells and the shelf, and among the cells, at least ``STAGING_FREE`` from
#: every other block on the table (below ``STAGING_LEVEL``), at most ``MAX_STAGING_SPOTS``
#: of them planned.
STAGING_X = (0.44, 0.36)
STAGING_Y = tuple(np.round(np.arange(-0.24, 0.241, 0.06), 3))
STAGING_FREE = 0.14
STAGING_LEVEL = 0.1
MAX_STAGING_SPOTS = 3
#: At most this many side grasps (with their places) are planned before the block is given
#: up where it lies (each costs 0.1-1 s; where one plans, one of the first usually does). A
#: count, not a time: the same scene plans the same on a busy machine.
MAX_TAKES = 40


def place_from_front(
    runner: PickAndPlace,
    action: Action,
    scene: Scene,
    status: Callable[[SkillState], SkillStatus],
) -> None:
    """Put the action's block into the action's slot."""
    item, goal = runner.object_and_goal(action, scene)
    status(SkillState.RUNNING)
    driver = runner.driver
    # A driver that moves objects as told, or a scene of another family whose goal ids look
    # like slots (``SkillFamily.takes`` sees the action only): the plain pick and place.
    if not isinstance(driver, PandaMotionDriver) or not is_shelf_scene(scene):
        pick, place = choose_grasps(scene, item, goal.position)
        driver.pick(Motion(action.decision_id, item.id, item.position, item.orientation, pick))
        driver.place(Motion(action.decision_id, item.id, goal.position, goal.orientation, place))
        return
    FrontPlace(driver, action.decision_id, scene, item).into(np.array(goal.position.as_tuple()))


class FrontPlace:
    """One block of ``scene`` taken off the table and put into a slot by the Panda
    ``driver``, for decision ``decision_id``."""

    def __init__(
        self, driver: PandaMotionDriver, decision_id: str, scene: Scene, item: SceneObject
    ) -> None:
        self.driver = driver
        self.decision = decision_id
        self.scene = scene
        self.item = item
        self.here = np.array(item.position.as_tuple())
        self.front_x = scene_geometry(scene).front_x

    def into(self, slot: np.ndarray) -> None:
        """Take the block and put it into the slot whose centre is ``slot``: from its side
        where it lies, else first moved top-down to a spot on the table where it can be
        (:meth:`_staging_spot`)."""
        self.slot = slot
        placing = scene_obstacles(self.scene, self.item, slot)
        chosen: list[Hand] = []

        def plan_pick(q: np.ndarray) -> JointTrajectory:
            pick, hand = self._plan_take(q, self.here, placing)
            chosen[:] = [hand]
            log.info("taking %s from its side: %s", self.item.id, hand)
            return pick

        taking = scene_obstacles(self.scene, self.item, self.here)
        try:
            held = self.driver.run_plan(self.decision, plan_pick, home_around=taking)
        except SkillError as exc:
            if exc.reason not in PLANNING_FAILURES:
                raise
            self._stage(self._staging_spot(exc))
            taking = scene_obstacles(self.scene, self.item, self.here)
            held = self.driver.run_plan(self.decision, plan_pick, home_around=taking)
        hand = chosen[0]
        if held.gripper_width < self.driver.min_grasp_width:
            self._let_go(hand)
            raise SkillError(
                "grasp_slipped",
                f"fingers closed to {held.gripper_width * 1000:.1f} mm: {self.item.id} not held",
            )

        placed: list[Carry] = []

        def plan_place(q: np.ndarray) -> JointTrajectory:
            contacts: dict[tuple[str, str], Contact] = {}
            found = self._place(q, hand, placing, contacts)
            if found is None:
                detail = refusal(contacts) if contacts else "no IK solution"
                raise SkillError("collision", f"into the shelf: {detail}")
            placed[:] = [found]
            return found.trajectory

        try:
            carried = self.driver.run_plan(self.decision, plan_place)
        except SkillError as exc:
            if exc.reason in ("collision", "no_ik_solution"):
                self._put_back(hand)
            raise
        if carried.gripper_width < self.driver.min_grasp_width:
            self._let_go(hand)
            raise SkillError("grasp_slipped", f"{self.item.id} was lost on the way in")
        released = self.driver.run_plan(
            self.decision,
            self.driver.plans.checked(
                lambda q: retreat(self.driver.planner, q, placed[0]), placing, OPENING
            ),
        )
        seen = self.driver.transport.object_position(self.item.id, after=released.stamp)
        if seen is not None:
            miss = float(np.linalg.norm(seen - slot))
            if miss > self.driver.placement_tolerance:
                raise SkillError(
                    "placement_missed", f"{self.item.id} rests {miss * 1000:.0f} mm from its slot"
                )

    def _plan_take(
        self, q: np.ndarray, here: np.ndarray, placing: tuple[Obstacle, ...]
    ) -> tuple[JointTrajectory, Hand]:
        """The first side grasp of the block lying at ``here``, planned from ``q``, after
        which its place into the slot also plans, both clear of the arm check; and its hand.
        ``collision`` or ``no_ik_solution`` if there is none."""
        taking = scene_obstacles(self.scene, self.item, here)
        contacts: dict[tuple[str, str], Contact] = {}
        tried = 0
        for hand in self._hands():
            for pick in side_pick(self.driver.planner, q, hand, here):
                self.driver.raise_if_stopped()
                tried += 1
                if tried > MAX_TAKES:
                    break
                if not self._clear(pick, taking, OPENING, contacts):
                    continue
                if self._place(pick.final, hand, placing, contacts) is None:
                    continue
                return pick, hand
        if contacts:
            raise SkillError("collision", f"taking it to the shelf: {refusal(contacts)}")
        raise SkillError("no_ik_solution", f"no side grasp of {self.item.id} reaches its slot")

    def _staging_spot(self, failure: SkillError) -> np.ndarray:
        """A free spot on the table from which the block's side grasp and place both plan
        (the nearest the slot's column first); ``failure`` if there is none."""
        others = [
            np.array(o.position.as_tuple())
            for o in self.scene.objects
            if o.id != self.item.id and o.position.z < STAGING_LEVEL
        ]
        placing = scene_obstacles(self.scene, self.item, self.slot)
        spots = [
            np.array([x, y, self.here[2]])
            for x in STAGING_X
            for y in sorted(STAGING_Y, key=lambda y: abs(y - float(self.slot[1])))
        ]
        free = [
            spot
            for spot in spots
            if all(np.linalg.norm((spot - other)[:2]) >= STAGING_FREE for other in others)
        ]
        for spot in free[:MAX_STAGING_SPOTS]:
            try:
                self._plan_take(HOME_Q, spot, placing)
            except SkillError:
                continue
            return spot
        raise failure

    def _stage(self, spot: np.ndarray) -> None:
        """Move the block top-down (the skills' own pick and place) to ``spot``, and take it
        as lying there."""
        log.info("moving %s to %s to take it from its side", self.item.id, np.round(spot, 3))
        target = Vector3(x=float(spot[0]), y=float(spot[1]), z=float(spot[2]))
        pick, place = choose_grasps(self.scene, self.item, target)
        item = self.item
        self.driver.pick(Motion(self.decision, item.id, item.position, item.orientation, pick))
        self.driver.place(Motion(self.decision, item.id, target, Quaternion(), place))
        seen = self.driver.transport.object_position(item.id, after=time.time())
        self.here = spot.copy() if seen is None else np.asarray(seen, dtype=float)
        self.item = item.replace(position=target, orientation=Quaternion())

    def _hands(self) -> list[Hand]:
        """The side hands to take the block with: each pitch, approaching square to its faces
        from the robot's side, then from either flank, the wrist either way round."""
        quaternion = self.item.orientation
        square = grasp_yaw((quaternion.x, quaternion.y, quaternion.z, quaternion.w))
        return [
            Hand(square + turn, pitch, flipped)
            for pitch in PICK_PITCHES
            for turn in (0.0, -np.pi / 2, np.pi / 2)
            for flipped in (False, True)
        ]

    def _place(
        self,
        q: np.ndarray,
        taken: Hand,
        obstacles: tuple[Obstacle, ...],
        contacts: dict[tuple[str, str], Contact],
    ) -> Carry | None:
        """The first place into the slot from ``q`` (holding, taken with ``taken``) whose
        moves, and the retreat after it, clear the arm check; None if there is none."""
        planner = self.driver.planner
        pitches = [p for p in PLACE_PITCHES if abs(p - taken.pitch) <= MAX_TILT + 1e-9]
        for pitch in sorted(pitches, key=lambda p: abs(p - taken.pitch)):
            hand = Hand(0.0, pitch, taken.flipped)
            way = approach_to(self.slot, self.front_x, pitch - taken.pitch)
            for carry in front_place(planner, q, hand, way):
                self.driver.raise_if_stopped()
                if not self._clear(carry.trajectory, obstacles, HOLDING, contacts):
                    continue
                back = retreat(planner, carry.trajectory.final, carry)
                if self._clear(back, obstacles, OPENING, contacts):
                    return carry
        return None

    def _clear(
        self,
        trajectory: JointTrajectory,
        obstacles: tuple[Obstacle, ...],
        opening: float,
        contacts: dict[tuple[str, str], Contact],
    ) -> bool:
        trajectory.opening = opening
        found = self.driver.plans.contact(trajectory, obstacles)
        if found is not None:
            contacts.setdefault((found.link, found.obstacle), found)
        return found is None

    def _let_go(self, hand: Hand) -> None:
        """Open where the hand is and draw back along the approach (after a lost grasp)."""
        planner = self.driver.planner

        def back_off(q: np.ndarray) -> JointTrajectory:
            trajectory = JointTrajectory()
            trajectory.add(0.0, q, closed=True)
            trajectory.hold(planner.config.grip_time, closed=False)
            here = planner.model.tcp_pose(q).translation
            line(planner, trajectory, hand, here - 0.05 * hand.approach, False, "back off")
            line(planner, trajectory, hand, here + np.array([0.0, 0.0, 0.08]), False, "rise")
            return trajectory

        try:
            self.driver.run_plan(self.decision, back_off)
        except SkillError as exc:
            log.info("could not back off from %s: %s", self.item.id, exc)

    def _put_back(self, hand: Hand) -> None:
        """Set the held block down where it was taken and let go (best effort)."""
        planner = self.driver.planner
        down = self.here + np.array([0.0, 0.0, 0.004])

        def set_down(q: np.ndarray) -> JointTrajectory:
            trajectory = JointTrajectory()
            trajectory.add(0.0, q, closed=True)
            line(planner, trajectory, hand, down, True, "put back")
            return trajectory

        try:
            self.driver.run_plan(self.decision, set_down)
        except SkillError as exc:
            log.info("could not put %s back: %s", self.item.id, exc)
            return
        self._let_go(hand)
