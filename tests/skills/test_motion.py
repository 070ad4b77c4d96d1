"""Pinocchio kinematics, DLS IK and the PickAndPlace trajectories of the Panda."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_skills.motion import (
    HOME_Q,
    GraspPlanner,
    IKSolver,
    JointTrajectory,
    PandaModel,
    PlanConfig,
)
from manigraph_skills.motion.model import top_down
from manigraph_skills.motion.plan import RETREAT_CLEAR_RISE, grasp_yaw


@pytest.fixture(scope="module")
def model() -> PandaModel:
    return PandaModel()


def test_the_model_is_the_shipped_panda(model: PandaModel) -> None:
    # ManiSkill's panda_v2.urdf, shipped with manigraph_shared (no mani-skill needed).
    assert model.urdf.name == "panda_v2.urdf" and "manigraph_shared" in str(model.urdf)
    assert model.model.nq == 7
    # The rest pose holds the hand above the table, fingers straight down.
    pose = model.tcp_pose(HOME_Q)
    assert pose.translation[2] > 0.1
    assert np.allclose(pose.rotation[:, 2], [0, 0, -1], atol=1e-6)


def test_ik_reaches_top_down_poses_across_the_workspace_within_a_millimetre(
    model: PandaModel,
) -> None:
    ik = IKSolver(model)
    rng = np.random.default_rng(0)
    for _ in range(50):
        target = top_down(
            [rng.uniform(0.3, 0.7), rng.uniform(-0.35, 0.35), rng.uniform(0.02, 0.3)],
            yaw=PlanConfig().hand_yaw + rng.uniform(-np.pi / 4, np.pi / 4),
        )
        result = ik.solve(target, HOME_Q)
        assert result.ok
        reached = model.tcp_pose(result.q)
        assert np.linalg.norm(reached.translation - target.translation) < 1e-3
        assert np.allclose(reached.rotation, target.rotation, atol=1e-2)
        assert model.within_limits(result.q)


def test_ik_refuses_a_pose_out_of_reach_with_the_reason(model: PandaModel) -> None:
    ik = IKSolver(model)
    far = top_down([1.5, 0.0, 0.3])
    assert not ik.solve(far, HOME_Q).ok
    with pytest.raises(SkillError) as caught:
        ik.solve_or_raise(far, HOME_Q, "grasp")
    assert caught.value.reason == "no_ik_solution"
    assert "grasp" in caught.value.detail


def test_ik_never_leaves_the_joint_limits(model: PandaModel) -> None:
    ik = IKSolver(model, max_iterations=50)
    rng = np.random.default_rng(1)
    for _ in range(20):
        # Seeds outside the limits and targets behind and under the robot push on them.
        seed = rng.uniform(model.lower - 1.0, model.upper + 1.0)
        target = top_down([rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(-0.2, 1)])
        assert model.within_limits(ik.solve(target, seed).q)


def test_ik_settings_are_validated_by_name(model: PandaModel) -> None:
    with pytest.raises(ConfigError, match=r"ik\.damping"):
        IKSolver(model, damping=0.0)
    with pytest.raises(ConfigError, match=r"plan\.speed"):
        PlanConfig(speed=-1.0)


def test_pick_and_place_trajectories_follow_the_waypoints(model: PandaModel) -> None:
    planner = GraspPlanner(model)
    block, goal = np.array([0.5, 0.2, 0.06]), np.array([0.4, -0.25, 0.02])
    pick = planner.pick(HOME_Q, block)
    place = planner.place(pick.final, goal)
    release = planner.release(place.final)
    config = planner.config
    lifted = block + np.array([0, 0, config.lift])
    assert np.allclose(model.tcp_pose(pick.final).translation, lifted, atol=1e-3)
    grasp_index = pick.closed.index(True)
    assert np.allclose(
        model.tcp_pose(pick.positions[grasp_index - 1]).translation, block, atol=1e-3
    )
    assert all(place.closed)
    above_goal = goal + np.array([0, 0, config.release_clearance])
    assert np.allclose(model.tcp_pose(place.final).translation, above_goal, atol=1e-3)
    assert not release.closed[-1]
    assert model.tcp_pose(release.final).translation[2] > above_goal[2] + 0.9 * config.retreat
    for trajectory in (pick, place, release):
        times = np.asarray(trajectory.times)
        assert np.all(np.diff(times) > 0)
        positions = np.asarray(trajectory.positions)
        assert all(model.within_limits(q) for q in positions)
        speed = np.abs(np.diff(positions, axis=0)) / np.diff(times)[:, None]
        # Straight-line samples are evenly spaced, the timing is min-jerk: speeds stay bounded.
        assert np.all(speed <= model.velocity_limit * 1.05)


def test_transfers_stay_above_the_carry_height(model: PandaModel) -> None:
    planner = GraspPlanner(model)
    pick = planner.pick(HOME_Q, np.array([0.6, 0.3, 0.02]))
    place = planner.place(pick.final, np.array([0.35, -0.3, 0.02]))
    heights = [model.tcp_pose(q).translation[2] for q in place.positions]
    travelled = [model.tcp_pose(q).translation[:2] for q in place.positions]
    mid = [h for h, xy in zip(heights, travelled, strict=True) if 0.0 < xy[1] < 0.1]
    assert mid and min(mid) >= planner.config.min_carry_z - 1e-3


def test_grasp_yaw_folds_a_cube_into_a_quarter_turn() -> None:
    half = np.sqrt(0.5)
    assert grasp_yaw((0.0, 0.0, 0.0, 1.0)) == pytest.approx(0.0)
    assert grasp_yaw((0.0, 0.0, half, half)) == pytest.approx(0.0, abs=1e-9)  # 90 degrees
    small = np.sin(np.radians(10))
    assert grasp_yaw((0.0, 0.0, small, np.cos(np.radians(10)))) == pytest.approx(np.radians(20))


@pytest.mark.parametrize("height", [0.02, 0.12, 0.22])
def test_every_corner_of_the_task_workspace_is_planned_from_the_rest_pose(
    model: PandaModel, height: float
) -> None:
    """Stacks of up to six blocks anywhere the tasks lay them out (x 0.3-0.7, y +-0.35)."""
    planner = GraspPlanner(model)
    corners = [(x, y) for x in (0.3, 0.7) for y in (-0.35, 0.35)]
    for x, y in corners:
        pick = planner.pick(HOME_Q, np.array([x, y, height]), yaw=planner.config.hand_yaw)
        for gx, gy in corners:
            if (gx, gy) != (x, y):
                place = planner.place(pick.final, np.array([gx, gy, height]))
                planner.release(place.final)


def test_a_release_far_out_and_high_that_cannot_rise_straight_draws_back_as_it_rises() -> None:
    model = PandaModel()
    planner = GraspPlanner(model)
    # A hand in a far corner of a pulled-out top rack's slots (found by scanning).
    hand = np.array([0.70, -0.32, 0.33])
    q = IKSolver(model).solve(top_down(hand, np.pi / 2), HOME_Q).q
    straight = JointTrajectory()
    straight.add(0.0, q, True)
    with pytest.raises(SkillError, match="retreat"):
        planner.line(straight, hand + np.array([0.0, 0.0, 0.06]), np.pi / 2, False, 0.2, "retreat")
    released = planner.release(q)
    end = model.tcp_pose(released.final).translation
    assert end[2] == pytest.approx(hand[2] + 0.06, abs=1e-3)
    assert hand[0] - 0.08 - 1e-3 <= end[0] < hand[0] - 0.01  # drawn back towards the robot
    assert released.closed[-1] is False


def test_a_release_that_draws_back_first_rises_clear_of_what_it_let_go_of() -> None:
    """Drawing back at once, the far open finger dragged a bowl along its rack and lifted it
    away with the hand: the fingers now rise straight until their tips clear it."""
    model = PandaModel()
    planner = GraspPlanner(model)
    hand = np.array([0.5, 0.1, 0.15])
    q = IKSolver(model).solve(top_down(hand, np.pi / 2), HOME_Q).q
    released = planner.release(q, back=0.05)
    path = np.array([model.tcp_pose(p).translation for p in released.positions])
    low = path[:, 2] < hand[2] + RETREAT_CLEAR_RISE - 1e-3
    assert np.abs(path[low, 0] - hand[0]).max() < 1e-3  # straight up while the fingers are low
    assert path[-1, 0] == pytest.approx(hand[0] - 0.05, abs=1e-3)  # then back
