"""The moves of a turn-over manoeuvre (a family's ``SkillFamily.turn_over``) as joint
trajectories: set a held dish down with the hand turned sideways, and let go of it.

*Set down sideways*: from the lifted top-down grasp up to the turning height, across to above
the spot with the hand turned about the vertical so its closing axis is the set-down one,
then a quarter turn about that (horizontal) axis (joint 7's turn with the hand horizontal), and
straight down until the dish is just above the counter. *Let go sideways*: open, draw the
hand back along its fingers, rise, and turn it top-down again, so the next (top-down) motion
starts as every other does.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pinocchio as pin

from manigraph_shared.errors import SkillError
from manigraph_skills.motion.plan import UP, GraspPlanner, turn_ways
from manigraph_skills.motion.trajectory import JointTrajectory

#: TCP height at which the hand turns, metres: the dish (at most ~4.5 cm from the TCP) and
#: the wrist swinging sideways stay clear of the counter and the dishes on it.
TURN_HEIGHT = 0.16
#: How far the hand backs off along its fingers after letting go, and then rises, metres: the
#: first that plans and clears the neighbours; 0 rises straight away (the open fingers slide
#: up past the dish's sides, the palm is beyond them).
BACK_OFFS = (0.08, 0.05, 0.03, 0.0)
RISE = 0.1


def closing_yaw(hand: np.ndarray) -> float:
    """The top-down yaw whose fingers close along ``hand``'s closing axis (its y column)."""
    closing = hand[:, 1]
    return float(np.arctan2(closing[0], -closing[1]))


def set_down_sideways(
    planner: GraspPlanner,
    q: np.ndarray,
    hand: np.ndarray,
    spot: np.ndarray,
    carry_z: float = 0.0,
) -> JointTrajectory:
    """From ``q`` (holding, top-down): the dish's centre to ``spot`` with the hand at
    rotation ``hand`` (sideways)."""
    c = planner.config
    spot = np.asarray(spot, dtype=float)
    turn_at = np.array([spot[0], spot[1], max(TURN_HEIGHT, carry_z)])
    trajectory = JointTrajectory()
    trajectory.add(0.0, q, closed=True)
    # The same hand either way round: turn the shorter way from the hand's yaw now.
    now = planner.yaw_of(q)
    yaw = turn_ways(now, closing_yaw(hand))[0]
    planner._transit(trajectory, turn_at, yaw, closed=True, what="turn-over transfer")
    planner.pose_line(trajectory, pin.SE3(hand, turn_at), True, c.slow_speed, "turn over")
    planner.pose_line(trajectory, pin.SE3(hand, spot), True, c.slow_speed, "set down turned")
    return trajectory


def let_go_sideways(planner: GraspPlanner, q: np.ndarray) -> Iterator[JointTrajectory]:
    """The ways to open where the hand is, back off along the fingers, rise and turn
    top-down, backing off less each time (``BACK_OFFS``); a way with no IK solution is left
    out, and if none has one the first's ``no_ik_solution`` is raised."""
    failure: SkillError | None = None
    planned = False
    for back in BACK_OFFS:
        try:
            way = _let_go(planner, q, back)
        except SkillError as exc:
            failure = failure or exc
            continue
        planned = True
        yield way
    if not planned:
        assert failure is not None
        raise failure


def _let_go(planner: GraspPlanner, q: np.ndarray, back_off: float) -> JointTrajectory:
    c = planner.config
    trajectory = JointTrajectory()
    trajectory.add(0.0, q, closed=True)
    trajectory.hold(c.grip_time, closed=False)
    pose = planner.model.tcp_pose(q)
    hand = pose.rotation
    back = pose.translation - back_off * hand[:, 2]
    planner.pose_line(trajectory, pin.SE3(hand, back), False, c.slow_speed, "back off")
    above = back + RISE * UP
    planner.pose_line(trajectory, pin.SE3(hand, above), False, c.slow_speed, "rise")
    yaw = closing_yaw(hand)
    c_, s_ = np.cos(yaw), np.sin(yaw)
    down = np.array([[c_, s_, 0.0], [s_, -c_, 0.0], [0.0, 0.0, -1.0]])
    planner.pose_line(trajectory, pin.SE3(down, above), False, c.slow_speed, "turn top-down")
    return trajectory
