"""The Panda's moves for the shelf, as joint trajectories from the skills' own IK and
straight-line sampling (``GraspPlanner.pose_line``): a side grasp off the table, and the
horizontal-approach place into a slot from the front, under the board above.

**Why a side grasp, pitched.** A top-down hand cannot reach into a slot: above a block in a
slot the hand and wrist need some 40 cm (the wrist's links 6 and 7 stand 16-30 cm over the
TCP), and a level is 17 cm high. A hand pointing into the shelf (+x) with its fingers closing
across it (along y) is 6 cm thick near the fingers and 9 cm at the wrist, so it fits under
the board above. Exactly level, though, its wrist (link 7, 4.4 cm around the hand's axis,
10-16 cm behind the TCP) hangs below a block's centre, into the board or table the block
stands on; pitched down by :data:`PITCHES` (11-17 degrees) it rises clear behind the block and
still passes under the board above. The block is held as it was taken, so it must be taken
with the same pitch to stand flat where it is set down: it is taken off the table from its
side, the hand pitched as it will place it. (A top-down grasp turned a quarter over would
need the hand exactly level.) The Panda reaches such poses near the table only with its wrist
turned over (joint 5 near its limit): the hand gets there by a joint-space move from high up
(:func:`joint_move`), then moves in straight lines.

**Pick** (:func:`side_pick`): from above, down to 5 cm behind the block along the hand's
approach, straight in until the TCP is at the block's centre (a few millimetres above it),
close, lift. **Place** (:func:`front_place`): across at the carry height to in front of the
slot's column, down outside the shelf to the entry height, in under the board above to
:data:`DIVE_DEPTH` inside the shelf (the hand's rear clears the blocks on the table there),
down to just above the slot's floor, in along +x to the slot, down until the block is
:data:`RELEASE` over its floor. **Retreat** (:func:`retreat`): open, and the same way back out.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from manigraph_shared.errors import SkillError
from manigraph_shelf.shelf_geometry import OBJECT_SIZE
from manigraph_skills.motion import GraspPlanner, JointTrajectory
from manigraph_skills.motion.model import HOME_Q

#: How far the hand's approach is pitched down from level, radians, in the order tried: to
#: take a block off the table (steeper, the hand's rear rises over its neighbours), and to set
#: it into a slot (flatter, the wrist passes under the board above).
PICK_PITCHES = (0.2, 0.3, 0.4)
PLACE_PITCHES = (0.2, 0.15, 0.25)
#: At most this much steeper or flatter the hand may place than it took, radians: the block
#: is let go tilted so much, a corner first, and settles flat.
MAX_TILT = 0.2
#: TCP above the block's centre when holding it, metres (the pads cover its middle).
GRASP_RAISE = 0.004
#: How far behind the block (along the approach) the fingers come down, metres.
PREGRASP_BACK = 0.05
PREGRASP_RISE = 0.02
#: Lift after closing, metres.
LIFT = 0.08
#: TCP height for moves across the table, metres: a held block's underside 4 cm over the
#: others' tops.
CARRY_Z = 0.13
#: Least TCP height of a joint move's high point (:func:`high_via`), metres.
VIA_Z = 0.3
#: The block's front face this far in front of the shelf where it comes down outside it.
ENTRY_GAP = 0.02
#: TCP height above a slot's centre while entering the shelf, metres: the hand's rear clears
#: the blocks on the table, its top the board above.
ENTRY_RISE = 0.045
#: How far inside the shelf's front the hand comes down to the slot's height, metres (at
#: most the slot's own depth): its rear (13 cm behind the TCP) then clears the table's blocks.
DIVE_DEPTH = 0.08
#: The block is carried in this far above where it is let go, and let go this far above its
#: floor, metres.
SLIDE_RISE = 0.01
RELEASE = 0.003
#: Cartesian speeds, m/s.
SPEED = 0.4
SLOW = 0.15
#: At most this many IK solutions of one pose are tried (each a way to plan on).
MAX_SOLUTIONS = 6
#: A joint move holding a block runs at this fraction of the planner's joint speeds: at
#: full speed the wrist turning over flung a block out of the fingers.
HOLDING_JOINT_SPEED = 0.3
#: A joint move holding a block turns no joint further than this, radians: swung round
#: further (the wrist turning over with it), the block slid out of the fingers.
MAX_HOLDING_SWING = 1.2
#: Joint-space samples of a joint move.
JOINT_SAMPLES = 40


@dataclass(frozen=True)
class Hand:
    """A side hand: pointing ``yaw`` about the vertical, ``pitch`` down from level, closing
    along ``+y`` of its yaw or (``flipped``) along ``-y`` (the same grasp, the wrist
    half a turn round)."""

    yaw: float
    pitch: float
    flipped: bool = False

    @property
    def rotation(self) -> np.ndarray:
        """The TCP frame: z along the approach, y the closing axis (horizontal)."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        approach = np.array([c * np.cos(self.pitch), s * np.cos(self.pitch), -np.sin(self.pitch)])
        closing = np.array([-s, c, 0.0]) * (-1.0 if self.flipped else 1.0)
        return np.column_stack([np.cross(closing, approach), closing, approach])

    @property
    def approach(self) -> np.ndarray:
        return self.rotation[:, 2]

    def at(self, position: np.ndarray) -> pin.SE3:
        return pin.SE3(self.rotation, np.asarray(position, dtype=float))


def _seeds() -> list[np.ndarray]:
    """Starting points for IK of a side hand near the table: the wrist turned over (joint 5
    near either limit), the shoulder and elbow spread over their ranges; fixed, so every plan
    is the same for the same scene."""
    rng = np.random.default_rng(20261208)
    seeds = [
        np.array([j1, j2, j3, -2.1, j5, 2.1, j7])
        for j5 in (2.7, -2.7)
        for j1, j2, j3 in ((-0.9, 1.2, 0.9), (0.9, 1.2, -0.9), (0.0, 0.8, 0.0), (1.6, -1.7, -1.9))
        for j7 in (0.0, 1.5, -1.5)
    ]
    low = np.array([-2.8, -1.7, -2.8, -3.0, -2.8, 0.0, -2.8])
    high = np.array([2.8, 1.7, 2.8, -0.1, 2.8, 3.7, 2.8])
    seeds += [low + rng.random(7) * (high - low) for _ in range(24)]
    return seeds


SEEDS = _seeds()


def solutions(planner: GraspPlanner, pose: pin.SE3, near: np.ndarray) -> Iterator[np.ndarray]:
    """IK solutions of ``pose``, from ``near`` first, then the fixed seeds, each new one
    (more than 0.3 rad from those before) once, at most :data:`MAX_SOLUTIONS`."""
    found: list[np.ndarray] = []
    for seed in [near, HOME_Q, *SEEDS]:
        result = planner.ik.solve(pose, seed, restart=False)
        if not result.ok or any(np.max(np.abs(result.q - q)) < 0.3 for q in found):
            continue
        found.append(result.q)
        yield result.q
        if len(found) == MAX_SOLUTIONS:
            return


def joint_move(
    planner: GraspPlanner, trajectory: JointTrajectory, q: np.ndarray, closed: bool
) -> None:
    """Append a straight joint-space move from the trajectory's end to ``q``."""
    start = trajectory.final
    path = start + np.linspace(0.0, 1.0, JOINT_SAMPLES)[:, None] * (q - start)
    speed = planner.joint_speed * (HOLDING_JOINT_SPEED if closed else 1.0)
    trajectory.add_segment(path, closed, 0.0, SPEED, speed)


def line(
    planner: GraspPlanner,
    trajectory: JointTrajectory,
    hand: Hand,
    end: np.ndarray,
    closed: bool,
    what: str,
    speed: float = SLOW,
) -> None:
    """A straight TCP line to ``end`` with the hand turning to ``hand`` on the way."""
    planner.pose_line(trajectory, hand.at(end), closed, speed, what)


def rise(planner: GraspPlanner, trajectory: JointTrajectory, height: float, closed: bool) -> None:
    """Straight up to ``height`` as the hand is (nothing if it is there or higher, or if it
    cannot rise straight)."""
    pose = planner.model.tcp_pose(trajectory.final)
    if pose.translation[2] >= height:
        return
    up = pose.translation.copy()
    up[2] = height
    try:
        attempt = JointTrajectory()
        attempt.add(0.0, trajectory.final, closed)
        planner.pose_line(attempt, pin.SE3(pose.rotation, up), closed, SPEED, "rise")
    except SkillError:
        return
    base = trajectory.duration
    for t, q in zip(attempt.times[1:], attempt.positions[1:], strict=True):
        trajectory.add(base + t, q, closed)


def side_pick(
    planner: GraspPlanner, q: np.ndarray, hand: Hand, centre: np.ndarray
) -> Iterator[JointTrajectory]:
    """The ways (one per IK solution of the pose over the pregrasp, each reached by a joint
    move or by one through :func:`high_via`) to take the block whose centre is ``centre``
    with ``hand``: from ``q`` (empty), up, over to above the pregrasp, down behind the block,
    in, close, lift."""
    grasp = centre + np.array([0.0, 0.0, GRASP_RAISE])
    pregrasp = grasp - PREGRASP_BACK * hand.approach + np.array([0.0, 0.0, PREGRASP_RISE])
    over = np.array([pregrasp[0], pregrasp[1], CARRY_Z])
    start = JointTrajectory()
    start.add(0.0, q, closed=False)
    rise(planner, start, CARRY_Z, closed=False)
    for target in solutions(planner, hand.at(over), start.final):
        for via in _vias(planner, start.final, target):
            trajectory = _copy(start)
            try:
                for point in via:
                    joint_move(planner, trajectory, point, closed=False)
                line(planner, trajectory, hand, pregrasp, False, "pregrasp", SPEED)
                line(planner, trajectory, hand, grasp, False, "side grasp")
                trajectory.hold(planner.config.grip_time, closed=True)
                line(planner, trajectory, hand, grasp + np.array([0.0, 0.0, LIFT]), True, "lift")
            except SkillError:
                continue
            yield trajectory


def high_via(planner: GraspPlanner, q: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    """A point to pass on a joint move from ``q`` to ``target``: the shoulder and elbow
    folded up as at home, the base and wrist joints already as at ``target``, so the wrist
    turns over high above everything and the arm then unfolds down to ``target``. None where
    that point is not high (the hand over :data:`VIA_Z`)."""
    via = target.copy()
    via[1], via[3] = HOME_Q[1], HOME_Q[3]
    via = planner.model.clamp(via)
    return via if planner.model.tcp_pose(via).translation[2] >= VIA_Z else None


def _vias(planner: GraspPlanner, q: np.ndarray, target: np.ndarray) -> list[list[np.ndarray]]:
    """The joint moves to try from ``q`` to ``target``: straight, then by :func:`high_via`."""
    ways = [[target]]
    via = high_via(planner, q, target)
    if via is not None:
        ways.append([via, target])
    return ways


@dataclass(frozen=True)
class Approach:
    """The waypoints (TCP positions) of a place into a slot from the front: over the entry
    (``over``), the entry outside the shelf (``entry``), inside at the entry height
    (``inside``), down at the slot's height plus the slide rise (``low``), in front of the
    slot's centre at that height (``slide``), and where the block is let go (``release``)."""

    over: np.ndarray
    entry: np.ndarray
    inside: np.ndarray
    low: np.ndarray
    slide: np.ndarray
    release: np.ndarray


def approach_to(slot: np.ndarray, front_x: float, tilt: float = 0.0) -> Approach:
    """The waypoints to set a block's centre down at ``slot`` (a slot's centre), the shelf's
    open side at ``front_x``, the block held ``tilt`` radians off square (its lowest edge
    :data:`RELEASE` over the floor)."""
    x, y, z = (float(v) for v in slot)
    corner = OBJECT_SIZE / 2 * (np.cos(tilt) + np.sin(abs(tilt))) - OBJECT_SIZE / 2
    held = z + RELEASE + corner + GRASP_RAISE
    entry_x = front_x - ENTRY_GAP - 0.02  # the block's front face ENTRY_GAP before the shelf
    dive_x = min(front_x + DIVE_DEPTH, x)
    entry_z = held + ENTRY_RISE
    return Approach(
        over=np.array([entry_x, y, max(CARRY_Z, entry_z)]),
        entry=np.array([entry_x, y, entry_z]),
        inside=np.array([dive_x, y, entry_z]),
        low=np.array([dive_x, y, held + SLIDE_RISE]),
        slide=np.array([x, y, held + SLIDE_RISE]),
        release=np.array([x, y, held]),
    )


def front_place(planner: GraspPlanner, q: np.ndarray, hand: Hand, way: Approach) -> Iterator[Carry]:
    """The ways to carry the held block from ``q`` into its slot by ``way``, ``hand``
    pointing into the shelf: up to the carry height, across (turning to ``hand``), down,
    in and down to where it is let go. A straight move across first; where that has no IK
    solution, joint-space moves to each IK solution of the pose over the entry."""
    start = JointTrajectory()
    start.add(0.0, q, closed=True)
    rise(planner, start, CARRY_Z, closed=True)
    ways: list[JointTrajectory] = []
    direct = _copy(start)
    try:
        line(planner, direct, hand, way.over, True, "across", SPEED)
        ways.append(direct)
    except SkillError:
        pass

    def by_joints() -> Iterator[JointTrajectory]:
        for target in solutions(planner, hand.at(way.over), start.final):
            if float(np.max(np.abs(target - start.final))) > MAX_HOLDING_SWING:
                continue
            for via in [[target]]:
                moved = _copy(start)
                for point in via:
                    joint_move(planner, moved, point, closed=True)
                yield moved

    for carried in [*ways, *by_joints()]:
        inward = len(carried) - 1
        try:
            line(planner, carried, hand, way.entry, True, "down to the shelf", SPEED)
            line(planner, carried, hand, way.inside, True, "into the shelf")
            line(planner, carried, hand, way.low, True, "down to the slot")
            line(planner, carried, hand, way.slide, True, "slide in")
            line(planner, carried, hand, way.release, True, "set down")
        except SkillError:
            continue
        yield Carry(carried, inward)


@dataclass(frozen=True)
class Carry:
    """A place's moves (``trajectory``), whose moves in from over the entry begin at its
    point ``inward``."""

    trajectory: JointTrajectory
    inward: int


def retreat(planner: GraspPlanner, q: np.ndarray, carry: Carry) -> JointTrajectory:
    """Open where the hand is (``q``, where ``carry`` left it) and go back out exactly the
    way it came in from over the entry (its points from ``inward`` on, backwards), which the
    arm check cleared."""
    placed, inward = carry.trajectory, carry.inward
    trajectory = JointTrajectory()
    trajectory.add(0.0, q, closed=True)
    trajectory.hold(planner.config.grip_time, closed=False)
    times = placed.times[inward:]
    points = placed.positions[inward:]
    end = times[-1]
    base = trajectory.duration
    for t, point in zip(reversed(times[:-1]), reversed(points[:-1]), strict=True):
        trajectory.add(base + end - t, point, closed=False)
    return trajectory


def _copy(trajectory: JointTrajectory) -> JointTrajectory:
    copied = JointTrajectory(opening=trajectory.opening)
    for t, q, closed in zip(trajectory.times, trajectory.positions, trajectory.closed, strict=True):
        copied.add(t, q, closed)
    return copied
