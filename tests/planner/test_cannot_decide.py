"""A policy that cannot read an episode's scenes is asked once per episode, not per scene:
the planner refuses that episode once (``CannotDecide``) and the run client ends it."""

from __future__ import annotations

import pytest

from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.decision_failure import CannotDecide, cannot_decide
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import (
    Scene,
    SceneGoal,
    SceneObject,
    ServiceState,
    ServiceStatus,
    Vector3,
)

WHY = "scene: block 'b0' colour 'mauve' is not in this policy's vocabulary (blue, green, red)"


class Unreadable(Policy):
    """Refuses every scene, as a checkpoint does a colour it never saw; counts the asks."""

    name = "unreadable"

    def __init__(self) -> None:
        self.asked = 0

    def decide(self, scene: Scene) -> Decision | None:
        self.asked += 1
        raise PolicyError(WHY)


def scene(episode: str, sequence: int) -> Scene:
    block = SceneObject(
        id="b0",
        category="block",
        position=Vector3(x=0.4, y=0.0, z=0.02),
        size=Vector3(x=0.04, y=0.04, z=0.04),
        attributes={"colour": "mauve"},
    )
    goal = SceneGoal(id="g0", category="block", position=Vector3(x=0.3, y=0.0, z=0.02))
    return Scene(
        episode_id=episode, stamp=10.0 + sequence, sequence=sequence, objects=[block], goals=[goal]
    )


def test_an_unreadable_episode_is_refused_once_then_left_alone() -> None:
    policy = Unreadable()
    decisions = DecisionMaker(policy)
    with pytest.raises(CannotDecide) as refused:
        decisions.on_scene(scene("e1", 0))
    assert (refused.value.episode_id, refused.value.why) == ("e1", WHY)
    assert str(refused.value) == f"cannot_decide: episode e1: {WHY}"
    assert isinstance(refused.value, PolicyError)  # logged and published by the service
    for sequence in range(1, 50):  # 5 s of scenes at 10 Hz: not one more refusal
        assert decisions.on_scene(scene("e1", sequence)) is None
    assert policy.asked == 1
    with pytest.raises(CannotDecide):  # the next episode is asked again: once
        decisions.on_scene(scene("e2", 0))
    assert policy.asked == 2


def status(state: ServiceState, detail: str) -> ServiceStatus:
    return ServiceStatus(service="planner", state=state, detail=detail, stamp=1.0)


def test_the_run_client_reads_the_refusal_from_the_error_status_only() -> None:
    detail = str(CannotDecide("run-7:x.y", WHY))
    assert cannot_decide(status(ServiceState.ERROR, detail)) == ("run-7:x.y", WHY)
    # a heartbeat repeats the last error with state ok: it ends nothing
    assert cannot_decide(status(ServiceState.OK, detail)) is None
    assert cannot_decide(status(ServiceState.ERROR, "skill_timeout: decision e:3 given up")) is None
    assert cannot_decide(status(ServiceState.ERROR, "cannot_decide: episode nocolon")) is None
