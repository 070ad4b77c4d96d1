"""The physics backend with the Panda driver, in process: real SAPIEN contact physics."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import sapien
from sapien import physx

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.messages import (
    EpisodeRequest,
    GripperOp,
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    RobotCommand,
    SkillState,
    Vector3,
)
from manigraph_shared.workspace import Workspace
from manigraph_sim.backends import create_backend
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_sim.physics.physics_world import ARM_JOINTS, PhysicsConfig, use_own_physx_defaults
from manigraph_skills.drivers import Motion

Loop = Any  # tests/physics/conftest.py: Loop


def test_stacking_three_blocks_fills_every_goal_and_ends_the_episode(
    loop: Loop,
) -> None:
    loop.reset(blocks=3, seed=0)
    statuses = loop.stack_inverted(3)
    assert [s.state for s in statuses] == [SkillState.SUCCEEDED] * 3
    scene = loop.scene()
    assert all(goal.filled for goal in scene.goals) and scene.episode_ended
    end = loop.backend.end_event(time.time())
    assert end is not None and end.success and end.steps == 3 and end.goals_filled == 3
    assert loop.backend.end_event(time.time()) is None  # reported once


def test_same_seed_same_moves_same_final_poses(make_loop: Callable[..., Loop]) -> None:
    finals = []
    for _ in range(2):
        loop = make_loop()
        loop.reset(blocks=2, seed=7)
        loop.stack_inverted(2)
        finals.append([o.position.as_tuple() for o in loop.scene().objects])
    assert finals[0] == finals[1]


def test_physx_defaults_left_by_other_code_do_not_change_a_world(
    make_loop: Callable[..., Loop],
) -> None:
    """SAPIEN's PhysX defaults are process-wide, and ManiSkill sets its own on every
    environment it builds (these values): a world built afterwards must not run with them.
    Before the world set its own, a bowl test failed only after the ManiSkill tests."""

    def final_poses() -> list[tuple[float, float, float]]:
        loop = make_loop()
        loop.reset(blocks=2, seed=7)
        loop.stack_inverted(2)
        return [o.position.as_tuple() for o in loop.scene().objects]

    alone = final_poses()
    physx.set_shape_config(contact_offset=0.02, rest_offset=0.0)
    physx.set_body_config(solver_position_iterations=15, solver_velocity_iterations=1)
    physx.set_default_material(0.3, 0.3, 0.0)
    try:
        assert final_poses() == alone
    finally:
        use_own_physx_defaults()


def test_a_block_too_slippery_to_hold_is_reported_as_grasp_slipped(
    make_loop: Callable[..., Loop],
) -> None:
    loop = make_loop(config=PhysicsConfig(block_friction=0.0, finger_friction=0.0))
    loop.reset(blocks=2, seed=0)
    status = loop.move("block_1", "goal_0")
    assert status.state is SkillState.FAILED and status.reason == "grasp_slipped"
    assert not loop.backend.world.gripper_closed  # the driver opened up again
    assert not loop.scene().episode_ended  # the attempt counted; the planner may try again
    assert loop.backend.steps == 1


def test_a_target_outside_the_workspace_is_refused_before_any_motion(
    make_loop: Callable[..., Loop],
) -> None:
    loop = make_loop(Workspace(x=(0.1, 0.2)))
    loop.reset(blocks=2, seed=0)
    before = loop.backend.physics_steps
    status = loop.move("block_1", "goal_0")
    assert status.reason == "outside_workspace"
    assert loop.backend.physics_steps == before


def test_skills_failing_before_any_motion_still_spend_the_step_budget(
    make_loop: Callable[..., Loop],
) -> None:
    loop = make_loop(Workspace(x=(0.1, 0.2)))
    loop.reset(blocks=2, seed=0, max_steps=2)
    loop.move("block_1", "goal_0")
    assert not loop.scene().episode_ended
    loop.move("block_1", "goal_0")
    assert loop.scene().episode_ended
    end = loop.backend.end_event(time.time())
    assert end is not None and not end.success and end.steps == 2


def test_an_unreachable_target_is_refused_with_no_ik_solution(loop: Loop) -> None:
    loop.reset(blocks=2, seed=0)
    before = loop.backend.physics_steps
    far = Vector3(x=1.6, y=0.0, z=0.02)
    with pytest.raises(SkillError) as caught:
        loop.driver.pick(Motion("e0:1", "block_1", far, loop.scene().objects[0].orientation))
    assert caught.value.reason == "no_ik_solution"
    assert loop.backend.physics_steps == before


@pytest.mark.parametrize(("offset", "filled"), [(0.0, True), (0.015, True), (0.03, False)])
def test_goals_fill_by_the_documented_tolerance(offset: float, filled: bool) -> None:
    backend = create_backend("physics", goal_tolerance=0.02)
    backend.reset(EpisodeRequest(episode_id="e", task="stack", blocks=2, seed=0), 1.0)
    scene = backend.scene(1.0)
    assert scene is not None and not any(g.filled for g in scene.goals)
    goal = np.array(scene.goal("goal_0").position.as_tuple())
    backend.world.entities["block_1"].set_pose(sapien.Pose(goal + np.array([offset, 0.0, 0.001])))
    backend.world.step(40)  # let it settle on the table
    scene = backend.scene(1.0)
    assert scene.goal("goal_0").filled is filled
    assert scene.object("block_1").filled is filled


def test_the_physics_sim_refuses_cartesian_gripper_commands_and_unknown_tasks() -> None:
    backend = create_backend("physics")
    backend.reset(EpisodeRequest(episode_id="e", task="stack", blocks=2, seed=0), 1.0)
    command = RobotCommand(
        command_id="c",
        decision_id="d",
        op=GripperOp.PICK,
        object_id="block_0",
        position=Vector3(x=0.4, y=0.0, z=0.02),
        stamp=1.0,
    )
    assert backend.execute(command, 1.0).reason == "unsupported"
    with pytest.raises(ConfigError, match="task: 'boxes' is not one of"):
        backend.reset(EpisodeRequest(episode_id="b", task="boxes", blocks=2, seed=0), 1.0)


def test_physics_settings_are_validated_by_name() -> None:
    with pytest.raises(ConfigError, match=r"physics\.timestep"):
        PhysicsConfig(timestep=1.0)
    with pytest.raises(ConfigError, match=r"physics\.block_friction"):
        PhysicsConfig(block_friction=-1.0)
    with pytest.raises(ConfigError, match="goal_tolerance"):
        create_backend("physics", goal_tolerance=0.0)


def test_a_trajectory_planned_from_a_stale_state_is_replanned(loop: Loop) -> None:
    loop.reset(blocks=2, seed=0)
    loop.move("block_1", "goal_0")
    # A new episode puts the arm back home; a driver that remembered the old joints still
    # starts from where the arm really is.
    loop.reset(blocks=2, seed=1)
    status = loop.move("block_1", "goal_0")
    assert status.state is SkillState.SUCCEEDED
    assert np.isclose(loop.scene().objects[1].position.z, 0.02, atol=2e-3)


@pytest.mark.parametrize("realtime", [False, True])
def test_realtime_mode_keeps_pace_with_the_clock(realtime: bool) -> None:
    backend = PhysicsBackend(realtime=realtime)
    calls: list[float] = []
    backend.while_moving = lambda: calls.append(time.perf_counter())
    backend.reset(EpisodeRequest(episode_id="e", task="stack", blocks=1, seed=0), 1.0)
    q = backend.world.arm_q.tolist()
    command = JointTrajectoryCommand(
        command_id="c",
        decision_id="e:0",
        joint_names=list(ARM_JOINTS),
        points=[
            JointTrajectoryPoint(positions=q, gripper=GripperTarget.OPEN, time_from_start=0.0),
            JointTrajectoryPoint(positions=q, gripper=GripperTarget.OPEN, time_from_start=0.4),
        ],
        stamp=1.0,
    )
    started = time.perf_counter()
    assert backend.execute_trajectory(command, 1.0).ok
    wall = time.perf_counter() - started
    simulated = 0.4 + backend.config.settle_time
    assert wall >= 0.95 * simulated if realtime else wall < simulated / 2
    steps = round(simulated / backend.config.timestep)
    # In real time the sim service streams from every step of a motion; flat out, nothing.
    assert len(calls) == (steps if realtime else 0)
    assert backend.stream_rates == ((30.0, 100.0) if realtime else None)
    assert backend.sim_seconds() == pytest.approx(simulated, abs=2 * backend.config.timestep)


def test_the_end_event_reports_the_simulated_seconds(loop: Loop) -> None:
    loop.reset(blocks=1, seed=2)
    loop.move("block_0", "goal_0")
    end = loop.backend.end_event(time.time())
    assert end is not None and end.success
    # A PickAndPlace is seconds of motion: pregrasp, grasp, lift, transfer, place, retreat.
    assert 2.0 < end.sim_seconds < 30.0
    assert end.sim_seconds == pytest.approx(loop.backend.sim_seconds(), abs=1e-3)


def test_realtime_stream_rates_are_validated_by_name() -> None:
    with pytest.raises(ConfigError, match="scene_hz"):
        create_backend("physics", realtime=True, scene_hz=0)
    with pytest.raises(ConfigError, match="joint_state_hz"):
        create_backend("physics", realtime=True, joint_state_hz=500)
    backend = create_backend("physics", realtime=True, scene_hz=15, joint_state_hz=50)
    assert backend.stream_rates == (15, 50)  # type: ignore[attr-defined]


def test_the_fingers_open_as_wide_as_a_trajectory_asks() -> None:
    backend = PhysicsBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="stack", blocks=1, seed=0), 1.0)
    assert backend.world is not None
    q = backend.world.arm_q.tolist()

    def hold(opening: float | None) -> float:
        points = [
            JointTrajectoryPoint(
                positions=q, gripper=GripperTarget.OPEN, opening=opening, time_from_start=t
            )
            for t in (0.0, 0.5)
        ]
        command = JointTrajectoryCommand(
            command_id="c", decision_id="e:0", joint_names=list(ARM_JOINTS), points=points, stamp=1
        )
        result = backend.execute_trajectory(command, 1.0)
        assert result.ok
        return result.gripper_width

    assert hold(0.03) == pytest.approx(0.03, abs=0.002)
    assert hold(None) == pytest.approx(0.08, abs=0.002)
