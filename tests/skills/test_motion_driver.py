"""The Panda motion driver's checks, against a scripted robot at the hardware boundary
(the joint transport): what it sends, and how it reads the robot's answers."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.messages import (
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    Quaternion,
    Vector3,
)
from manigraph_skills.drivers import DRIVERS, Motion, create_driver
from manigraph_skills.drivers.base import Grasp
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.drivers.panda_sim import PandaSimDriver
from manigraph_skills.drivers.registry import MotionOptions
from manigraph_skills.motion import HOME_Q

BLOCK = Vector3(x=0.5, y=0.1, z=0.02)
GOAL = Vector3(x=0.4, y=-0.2, z=0.02)


class ScriptedArm:
    """Executes every trajectory perfectly; reports the finger opening and where the object
    rests as scripted (a real arm's sensors)."""

    def __init__(self, widths: list[float], rests: np.ndarray | None = None) -> None:
        self.q = HOME_Q.copy()
        self.widths = widths
        self.rests = rests
        self.sent: list[JointTrajectoryCommand] = []
        self.refuse_first = False

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        self.sent.append(command)
        if self.refuse_first:
            self.refuse_first = False
            return self._answer(command, 0.08, reason="start_mismatch")
        self.q = np.array(command.points[-1].positions)
        return self._answer(command, self.widths.pop(0))

    def _answer(
        self, command: JointTrajectoryCommand, width: float, reason: str | None = None
    ) -> JointTrajectoryResult:
        return JointTrajectoryResult(
            command_id=command.command_id,
            ok=reason is None,
            reason=reason,
            positions=self.q.tolist(),
            gripper_width=width,
            stamp=1.0,
        )

    def joint_positions(self) -> np.ndarray:
        return self.q.copy()

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        return self.rests

    def stop(self) -> None:
        self.stopped = True

    def resume(self) -> None:
        self.stopped = False

    def abort(self, reason: str) -> None:
        self.aborted = reason


def test_a_pick_and_place_sends_pick_carry_and_release_motions() -> None:
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08], rests=np.array(GOAL.as_tuple()))
    driver = PandaMotionDriver(arm)
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    driver.place(Motion("e:0", "block_0", GOAL, Quaternion()))
    pick, carry, release = arm.sent
    assert pick.points[0].gripper is GripperTarget.OPEN
    assert pick.points[-1].gripper is GripperTarget.CLOSED
    assert all(p.gripper is GripperTarget.CLOSED for p in carry.points)
    assert release.points[-1].gripper is GripperTarget.OPEN
    assert {c.decision_id for c in arm.sent} == {"e:0"}
    assert len({c.command_id for c in arm.sent}) == 3


def test_fingers_closing_on_nothing_is_grasp_slipped_and_the_hand_opens() -> None:
    arm = ScriptedArm(widths=[0.0, 0.08])
    with pytest.raises(SkillError) as caught:
        PandaMotionDriver(arm).pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert caught.value.reason == "grasp_slipped"
    assert arm.sent[-1].points[-1].gripper is GripperTarget.OPEN


def test_an_object_lost_during_the_transfer_is_grasp_slipped() -> None:
    arm = ScriptedArm(widths=[0.04, 0.001, 0.08])
    driver = PandaMotionDriver(arm)
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    with pytest.raises(SkillError, match="transfer") as caught:
        driver.place(Motion("e:0", "block_0", GOAL, Quaternion()))
    assert caught.value.reason == "grasp_slipped"


def test_an_object_resting_off_its_goal_is_placement_missed() -> None:
    off = np.array(GOAL.as_tuple()) + np.array([0.05, 0.0, 0.0])
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08], rests=off)
    driver = PandaMotionDriver(arm)
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    with pytest.raises(SkillError) as caught:
        driver.place(Motion("e:0", "block_0", GOAL, Quaternion()))
    assert caught.value.reason == "placement_missed" and "50 mm" in caught.value.detail


def test_an_arm_that_is_elsewhere_gets_a_plan_from_where_it_is() -> None:
    arm = ScriptedArm(widths=[0.04])
    arm.refuse_first = True
    PandaMotionDriver(arm).pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert len(arm.sent) == 2


def test_a_decision_whose_episode_ended_is_not_planned_again_in_the_next() -> None:
    """The world ended the episode during the motion and reset at once: the rest of it is
    answered ``start_mismatch``. Planned again from the new home pose, it ran in the next
    episode's world (and that episode's first pull of the top rack came to nothing); now
    nothing more is sent for it, and the next decision moves as usual."""
    arm = ScriptedArm(widths=[0.04])
    arm.refuse_first = True
    driver = PandaMotionDriver(arm)
    answer = arm.execute

    def ended_meanwhile(command: JointTrajectoryCommand) -> JointTrajectoryResult:
        driver.end_decision("e:9", "episode_ended")  # the end event, on another thread
        return answer(command)

    arm.execute = ended_meanwhile  # type: ignore[method-assign]
    with pytest.raises(SkillError) as caught:
        driver.pick(Motion("e:9", "block_0", BLOCK, Quaternion()))
    assert caught.value.reason == "episode_ended"
    assert len(arm.sent) == 1  # the refused motion only, not a second plan
    assert arm.aborted == "episode_ended"  # a motion of it under way is failed at once
    arm.execute = answer  # type: ignore[method-assign]
    driver.pick(Motion("f:0", "block_0", BLOCK, Quaternion()))
    assert [c.decision_id for c in arm.sent] == ["e:9", "f:0"]


def test_a_decision_id_used_again_moves_again_after_its_first_use_ended() -> None:
    """An episode id run twice (a log replayed, a seed re-run under its old id) brings its
    decision ids back; the end of the first run must not refuse the second."""
    arm = ScriptedArm(widths=[0.04, 0.04])
    driver = PandaMotionDriver(arm)
    driver.begin_decision("e:0")
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    driver.end_decision("e:0", "episode_ended")
    driver.begin_decision("e:0")  # the same id, a new run of it
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert [c.decision_id for c in arm.sent] == ["e:0", "e:0"]


def test_an_unreachable_object_sends_nothing() -> None:
    arm = ScriptedArm(widths=[])
    with pytest.raises(SkillError) as caught:
        PandaMotionDriver(arm).pick(
            Motion("e:0", "block_0", Vector3(x=1.5, y=0, z=0.02), Quaternion())
        )
    assert caught.value.reason == "no_ik_solution" and arm.sent == []


def test_a_slot_the_wrist_cannot_turn_to_is_reached_with_the_hand_turned_half_round() -> None:
    """Taken at the counter's far left corner with the wrist turned far (yaw -pi), a dish
    carried to a top-rack slot at yaw pi has no top-down solution there (joint 7 at its
    limit, both ways round): the fingers are alike, so the hand sets it down turned half
    round (yaw 0) instead of refusing it as ``no_ik_solution``."""
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08])  # held after the pick and the carry
    driver = PandaMotionDriver(arm, check_collisions=False)
    one_yaw = Grasp(other_turn=0.0)  # no other yaw of its own
    driver.pick_at("e:0", "bowl_0", np.array([0.46, -0.3, 0.02]), -np.pi, one_yaw)
    slot = Vector3(x=0.6, y=-0.25, z=0.34)
    to_slot = Grasp(turn=np.pi / 2, other_turn=0.0)  # the hand at yaw pi/2 + pi/2
    driver.place(Motion("e:0", "bowl_0", slot, Quaternion(), to_slot))
    carried = np.array(arm.sent[-2].points[-1].positions)
    assert driver.model.tcp_pose(carried).translation == pytest.approx(
        [0.6, -0.25, 0.343], abs=0.001
    )
    assert np.cos(driver.planner.yaw_of(carried)) == pytest.approx(1.0, abs=1e-3)


def test_the_driver_is_registered_and_validates_its_settings() -> None:
    assert DRIVERS["panda-sim"] is PandaSimDriver
    with pytest.raises(ConfigError, match=r"placement_tolerance: must be > 0 m, got 0\.0"):
        MotionOptions(placement_tolerance=0.0)
    with pytest.raises(ConfigError) as caught:
        create_driver("panda-sim", bus=None, min_grasp_width=0.1)
    assert caught.value.field == "driver.min_grasp_width"
    assert "must be in [0, 0.08) m" in caught.value.problem
    with pytest.raises(
        ConfigError, match=r"driver\.timeout: not an option of driver .franka. \(its: dry_run\)"
    ):
        create_driver("franka", bus=None, timeout=1.0)


def test_after_an_emergency_stop_nothing_is_sent_until_resume() -> None:
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08], rests=np.array(GOAL.as_tuple()))
    driver = PandaMotionDriver(arm)
    driver.stop()
    assert arm.stopped
    with pytest.raises(SkillError) as stopped:
        driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert stopped.value.reason == "stopped" and arm.sent == []
    driver.resume()
    driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert len(arm.sent) == 1 and not arm.stopped


def test_command_ids_of_a_64_character_decision_stay_valid() -> None:
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08], rests=np.array(GOAL.as_tuple()))
    driver = PandaMotionDriver(arm)
    decision = "d" * 64
    driver.pick(Motion(decision, "block_0", BLOCK, Quaternion()))
    driver.place(Motion(decision, "block_0", GOAL, Quaternion()))
    ids = [command.command_id for command in arm.sent]
    assert len(set(ids)) == 3 and all(len(i) <= 64 for i in ids)


def test_a_stop_and_resume_while_planning_never_moves_the_arm_for_that_decision() -> None:
    arm = ScriptedArm(widths=[0.04, 0.04, 0.08], rests=np.array(GOAL.as_tuple()))
    driver = PandaMotionDriver(arm)
    read = arm.joint_positions

    def stop_and_resume_while_planning() -> np.ndarray:  # the stop lands as planning starts
        driver.stop()
        driver.resume()
        arm.joint_positions = read  # type: ignore[method-assign]
        return read()

    arm.joint_positions = stop_and_resume_while_planning  # type: ignore[method-assign]
    with pytest.raises(SkillError) as stopped:
        driver.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    assert stopped.value.reason == "stopped" and arm.sent == []
    with pytest.raises(SkillError):  # the stopped decision stays stopped
        driver.place(Motion("e:0", "block_0", GOAL, Quaternion()))
    assert arm.sent == []
    driver.pick(Motion("e:1", "block_0", BLOCK, Quaternion()))  # the next decision moves
    assert len(arm.sent) == 1
