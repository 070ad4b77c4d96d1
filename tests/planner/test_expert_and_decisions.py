from __future__ import annotations

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.policies import load_policy
from manigraph_shared.messages import (
    EpisodeEvent,
    Scene,
    SceneGoal,
    SceneObject,
    SkillStatus,
    Vector3,
)

B = 0.04


def obj(name: str, x: float, level: int, filled: bool = False) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=0.0, z=(level + 0.5) * B),
        size=Vector3(x=B, y=B, z=B),
        filled=filled,
    )


def slot(name: str, x: float, level: int, filled: bool = False) -> SceneGoal:
    return SceneGoal(
        id=name, category="block", position=Vector3(x=x, y=0.0, z=(level + 0.5) * B), filled=filled
    )


def scene(
    objects: list[SceneObject], goals: list[SceneGoal], stamp: float = 10.0, seq: int = 1
) -> Scene:
    return Scene(episode_id="e", stamp=stamp, sequence=seq, objects=objects, goals=goals)


def test_expert_moves_the_highest_movable_block_to_the_lowest_free_goal() -> None:
    s = scene(
        [obj("a", 0.5, 0), obj("b", 0.5, 1), obj("c", 0.5, 2)],
        [slot("g2", 0.3, 2), slot("g0", 0.3, 0), slot("g1", 0.3, 1)],
    )
    decision = ExpertPolicy().decide(s)
    assert decision is not None
    assert (decision.object_id, decision.goal_id) == ("c", "g0")


def test_expert_skips_blocks_already_in_goals_and_filled_goals() -> None:
    s = scene(
        [obj("a", 0.5, 0), obj("b", 0.5, 1), obj("c", 0.3, 0, filled=True)],
        [slot("g0", 0.3, 0, filled=True), slot("g1", 0.3, 1)],
    )
    decision = ExpertPolicy().decide(s)
    assert decision is not None and (decision.object_id, decision.goal_id) == ("b", "g1")


def test_expert_has_nothing_to_do_when_every_goal_is_filled() -> None:
    s = scene([obj("a", 0.3, 0, filled=True)], [slot("g0", 0.3, 0, filled=True)])
    assert ExpertPolicy().decide(s) is None


def test_registered_policy_by_name() -> None:
    assert isinstance(load_policy("expert"), ExpertPolicy)


def status(decision_id: str, state: str, stamp: float) -> SkillStatus:
    reason = "grasp_slipped" if state == "failed" else None  # retried: not a refusal
    return SkillStatus(decision_id=decision_id, skill="p", state=state, reason=reason, stamp=stamp)


def test_one_decision_at_a_time_and_never_on_a_stale_scene() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0), obj("b", 0.5, 1)], [slot("g0", 0.3, 0), slot("g1", 0.3, 1)])
    first = maker.on_scene(scene(*world, stamp=10.0, seq=1))
    assert first is not None and first.decision_id == "e:0" and first.scene_sequence == 1
    assert maker.on_scene(scene(*world, stamp=10.5, seq=2)) is None  # skill still running
    maker.on_status(status("e:0", "running", 10.6))
    assert maker.on_scene(scene(*world, stamp=10.7, seq=3)) is None
    maker.on_status(status("e:0", "succeeded", 11.0))
    assert maker.on_scene(scene(*world, stamp=10.9, seq=4)) is None  # observed before the end
    second = maker.on_scene(scene(*world, stamp=11.1, seq=5))
    assert second is not None and second.decision_id == "e:1"


def test_a_scene_that_overtook_the_status_is_decided_on_when_the_status_arrives() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0), obj("b", 0.5, 1)], [slot("g0", 0.3, 0), slot("g1", 0.3, 1)])
    assert maker.on_scene(scene(*world, stamp=1.0, seq=1)) is not None
    assert maker.on_scene(scene(*world, stamp=1.5, seq=2)) is None  # before the skill ended
    assert maker.on_scene(scene(*world, stamp=2.5, seq=3)) is None  # after it, but early
    assert maker.on_scene(scene(*world, stamp=3.5, seq=4)) is None
    action = maker.on_status(status("e:0", "succeeded", 2.0))
    assert action is not None and action.scene_sequence == 3  # the earliest fresh scene


def test_failed_skill_is_simply_followed_by_the_next_decision() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0)], [slot("g0", 0.3, 0)])
    assert maker.on_scene(scene(*world, stamp=1.0)) is not None
    maker.on_status(status("e:0", "failed", 2.0))
    retry = maker.on_scene(scene(*world, stamp=2.5, seq=2))
    assert retry is not None and retry.decision_id == "e:1"


def test_no_decisions_after_the_episode_ended_and_fresh_ids_for_the_next() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0)], [slot("g0", 0.3, 0)])
    maker.on_episode(
        EpisodeEvent(
            episode_id="e",
            phase="end",
            task="stack",
            seed=0,
            goals_total=1,
            goals_filled=0,
            success=False,
            stamp=1.0,
        )
    )
    assert maker.on_scene(scene(*world, stamp=5.0)) is None
    nxt = Scene(episode_id="f", stamp=6.0, sequence=9, objects=world[0], goals=world[1])
    action = maker.on_scene(nxt)
    assert action is not None and action.decision_id == "f:0"


def test_a_scene_of_an_ended_episode_is_never_decided_on() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0)], [slot("g0", 0.3, 0)])
    ended = Scene(
        episode_id="e", stamp=1.0, sequence=1, objects=world[0], goals=world[1], episode_ended=True
    )
    assert maker.on_scene(ended) is None
    assert maker.on_scene(scene(*world, stamp=2.0, seq=2)) is None  # the episode stays over


def test_a_decision_refused_because_the_robot_is_stopped_holds_the_planner_a_second() -> None:
    maker = DecisionMaker(ExpertPolicy())
    world = ([obj("a", 0.5, 0)], [slot("g0", 0.3, 0)])
    assert maker.on_scene(scene(*world, stamp=1.0)) is not None
    stopped = SkillStatus(decision_id="e:0", skill="p", state="failed", reason="stopped", stamp=2.0)
    assert maker.on_status(stopped) is None  # no decision on the held scenes either
    assert maker.on_scene(scene(*world, stamp=2.5, seq=2)) is None  # within the back-off
    again = maker.on_scene(scene(*world, stamp=3.1, seq=3))
    assert again is not None and again.decision_id == "e:1"
