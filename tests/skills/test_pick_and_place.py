from __future__ import annotations

import pytest

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.messages import (
    Action,
    Scene,
    SceneGoal,
    SceneObject,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_shared.workspace import Workspace
from manigraph_skills.drivers.base import Motion, RobotDriver
from manigraph_skills.pick_and_place import PickAndPlace


class RecordingArm(RobotDriver):
    """The hardware boundary: records what it was asked and fails when told to."""

    name = "recording-arm"

    def __init__(self, fail_pick: str | None = None) -> None:
        self.calls: list[tuple[str, str, tuple[float, float, float]]] = []
        self.fail_pick = fail_pick

    def pick(self, motion: Motion) -> None:
        self.calls.append(("pick", motion.object_id, motion.position.as_tuple()))
        if self.fail_pick:
            raise SkillError(self.fail_pick, "as told")

    def place(self, motion: Motion) -> None:
        self.calls.append(("place", motion.object_id, motion.position.as_tuple()))

    def stop(self) -> None:
        self.calls.append(("stop", "", (0.0, 0.0, 0.0)))

    def resume(self) -> None:
        self.calls.append(("resume", "", (0.0, 0.0, 0.0)))


def scene(goal_x: float = 0.4) -> Scene:
    return Scene(
        episode_id="e",
        stamp=1.0,
        sequence=1,
        objects=[
            SceneObject(
                id="a",
                category="block",
                position=Vector3(x=0.5, y=0, z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
        ],
        goals=[SceneGoal(id="g", category="block", position=Vector3(x=goal_x, y=0.1, z=0.02))],
    )


def action(object_id: str = "a", goal_id: str = "g") -> Action:
    return Action(
        decision_id="e:0",
        episode_id="e",
        scene_sequence=1,
        object_id=object_id,
        goal_id=goal_id,
        policy="expert",
        stamp=1.0,
    )


def run(arm: RobotDriver, act: Action, observed: Scene | None) -> list[SkillStatus]:
    reports: list[SkillStatus] = []
    PickAndPlace(arm, Workspace()).execute(act, observed, reports.append)
    return reports


def test_success_reports_accepted_running_succeeded_and_moves_to_the_goal() -> None:
    arm = RecordingArm()
    reports = run(arm, action(), scene())
    assert [r.state for r in reports] == [
        SkillState.ACCEPTED,
        SkillState.RUNNING,
        SkillState.SUCCEEDED,
    ]
    assert arm.calls == [("pick", "a", (0.5, 0.0, 0.02)), ("place", "a", (0.4, 0.1, 0.02))]


def test_target_outside_the_workspace_is_refused_before_any_motion() -> None:
    arm = RecordingArm()
    reports = run(arm, action(), scene(goal_x=1.5))
    assert reports[-1].state is SkillState.FAILED
    assert reports[-1].reason == "outside_workspace"
    assert arm.calls == []


@pytest.mark.parametrize(
    ("act", "reason"), [(action("zz"), "unknown_object"), (action("a", "zz"), "unknown_goal")]
)
def test_unknown_ids_fail_with_a_reason(act: Action, reason: str) -> None:
    assert run(RecordingArm(), act, scene())[-1].reason == reason


def test_driver_failure_is_reported_with_its_reason() -> None:
    reports = run(RecordingArm(fail_pick="grasp_slipped"), action(), scene())
    assert reports[-1].state is SkillState.FAILED and reports[-1].reason == "grasp_slipped"


def test_no_observation_of_the_episode_fails_honestly() -> None:
    assert run(RecordingArm(), action(), None)[-1].reason == "no_scene"


def test_workspace_parse_names_bad_bounds() -> None:
    assert Workspace.parse("0,1,-1,1,0,1").contains(Vector3(x=0.5, y=0, z=0.5))
    with pytest.raises(ConfigError, match=r"workspace\.x"):
        Workspace.parse("1,0,-1,1,0,1")
    with pytest.raises(ConfigError, match="six numbers"):
        Workspace.parse("a,b")
