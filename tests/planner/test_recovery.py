"""Recovery from decisions that made no progress (manigraph_planner.recovery)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_lab import episode_loop
from manigraph_lab.episode_loop import run_episode
from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.base import Decision, Policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_planner.recovery import ProgressMonitor, Verdict
from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    Scene,
    SceneGoal,
    SceneObject,
    SkillStatus,
    Vector3,
)

REPO = Path(__file__).resolve().parents[2]
B = 0.04


def obj(name: str, x: float, level: int) -> SceneObject:
    size = Vector3(x=B, y=B, z=B)
    return SceneObject(
        id=name, category="block", position=Vector3(x=x, y=0.0, z=(level + 0.5) * B), size=size
    )


def slot(name: str, x: float, level: int, filled: bool = False) -> SceneGoal:
    position = Vector3(x=x, y=0.0, z=(level + 0.5) * B)
    return SceneGoal(id=name, category="block", position=position, filled=filled)


def scene(objects: list, goals: list, stamp: float = 1.0, seq: int = 1) -> Scene:
    return Scene(episode_id="e", stamp=stamp, sequence=seq, objects=objects, goals=goals)


class Preferences(Policy):
    """Always the same ranking of pairs, whatever the scene (first: its decision)."""

    name = "preferences"

    def __init__(self, *pairs: tuple[str, str]) -> None:
        self.pairs = [Decision(o, g) for o, g in pairs]

    def decide(self, scene: Scene) -> Decision | None:
        return self.pairs[0]

    def ranked(self, scene: Scene) -> list[Decision]:
        return list(self.pairs)


def finished(action: Action, stamp: float, reason: str | None = None) -> SkillStatus:
    state = "failed" if reason else "succeeded"
    return SkillStatus(
        decision_id=action.decision_id, skill="p", state=state, reason=reason, stamp=stamp
    )


def play(maker: DecisionMaker, worlds: list, reasons: list[str | None]) -> list[Action]:
    """Decide on each world in turn, the skill ending with each reason (None: success)."""
    actions = []
    for step, (world, reason) in enumerate(zip(worlds, reasons, strict=True)):
        action = maker.on_scene(scene(*world, stamp=10.0 * step + 1, seq=step + 1))
        assert action is not None
        actions.append(action)
        maker.on_status(finished(action, 10.0 * step + 2, reason))
    return actions


UNCHANGED = ([obj("a", 0.5, 0), obj("b", 0.5, 1)], [slot("g0", 0.3, 0), slot("g1", 0.3, 1)])


def test_a_decision_that_changed_nothing_gives_way_to_the_next_pair_then_escalates() -> None:
    policy = Preferences(("a", "g0"), ("a", "g1"), ("b", "g0"), ("b", "g1"))
    actions = play(DecisionMaker(policy), [UNCHANGED] * 4, [None] * 4)
    chosen = [(a.object_id, a.goal_id, a.rank, a.recovery) for a in actions]
    assert chosen == [
        ("a", "g0", 0, None),  # the policy's own choice
        ("a", "g1", 1, "no_progress"),  # the world did not change: the next pair
        ("b", "g0", 2, "no_progress"),  # object a failed twice: every pair with a is skipped
        ("b", "g1", 3, "no_progress"),
    ]


def test_a_policy_may_have_an_object_passed_over_after_one_pair() -> None:
    """The dishwasher policy's dishes: what fails is taking or turning the dish, whichever
    slot it was for, so its other slots are not tried before the other dishes."""

    class OneFailure(Preferences):
        object_escalation = 1

    policy = OneFailure(("a", "g0"), ("a", "g1"), ("b", "g0"), ("b", "g1"))
    actions = play(DecisionMaker(policy), [UNCHANGED] * 3, [None] * 3)
    assert [(a.object_id, a.goal_id, a.recovery) for a in actions] == [
        ("a", "g0", None),
        ("b", "g0", "no_progress"),  # not a's other slot (with two, as above, it is)
        ("a", "g0", "exhausted"),  # nor b's: each failed once, no goal filled since
    ]
    with pytest.raises(ValueError, match="object_escalation"):
        ProgressMonitor(object_escalation=0)


def test_every_alternative_failed_the_first_choice_again_marked_exhausted() -> None:
    policy = Preferences(("a", "g0"), ("b", "g0"))
    actions = play(DecisionMaker(policy), [UNCHANGED] * 3, [None] * 3)
    assert [(a.object_id, a.recovery) for a in actions] == [
        ("a", None),
        ("b", "no_progress"),
        ("a", "exhausted"),
    ]


def test_a_slipped_grasp_is_retried_twice_before_it_counts_as_no_progress() -> None:
    policy = Preferences(("a", "g0"), ("b", "g0"))
    actions = play(DecisionMaker(policy), [UNCHANGED] * 4, ["grasp_slipped"] * 4)
    assert [(a.object_id, a.rank) for a in actions] == [("a", 0), ("a", 0), ("a", 0), ("b", 1)]
    assert actions[3].recovery == "no_progress"


def test_a_pair_repeated_with_no_goal_filled_since_gives_way_even_if_the_world_moved() -> None:
    policy = Preferences(("a", "g0"), ("b", "g0"))
    moved = [([obj("a", x, 0), obj("b", 0.7, 0)], [slot("g0", 0.3, 0)]) for x in (0.5, 0.55)]
    actions = play(DecisionMaker(policy), moved, [None, None])
    assert [(a.object_id, a.recovery) for a in actions] == [("a", None), ("b", "repeated_pair")]


def test_progress_clears_what_was_passed_over() -> None:
    policy = Preferences(("a", "g0"), ("b", "g1"))
    filled = ([obj("a", 0.5, 0), obj("b", 0.5, 1)], [slot("g0", 0.3, 0, True), slot("g1", 0.3, 1)])
    actions = play(DecisionMaker(policy), [UNCHANGED, UNCHANGED, filled], ["x", None, None])
    assert [(a.object_id, a.rank) for a in actions] == [("a", 0), ("b", 1), ("a", 0)]


def test_the_world_compares_within_tolerance() -> None:
    monitor = ProgressMonitor(tolerance=0.005)
    before = scene(*UNCHANGED)
    nudged = scene([obj("a", 0.503, 0), obj("b", 0.5, 1)], UNCHANGED[1])
    moved = scene([obj("a", 0.51, 0), obj("b", 0.5, 1)], UNCHANGED[1])
    assert monitor.same_world(before, nudged) and not monitor.same_world(before, moved)
    with pytest.raises(ValueError, match="tolerance"):
        ProgressMonitor(tolerance=-1)


def test_the_gnn_ranking_starts_with_its_decision_and_holds_only_compatible_pairs() -> None:
    policy = load_policy(str(REPO / "checkpoints" / "gat.pt"))
    assert isinstance(policy, GNNPolicy)
    world = scene(*UNCHANGED)
    ranked = policy.ranked(world)
    assert ranked[0] == policy.decide(world)
    assert sorted(d.pair for d in ranked) == [("a", "g0"), ("a", "g1"), ("b", "g0"), ("b", "g1")]


def test_the_expert_lists_its_alternatives_after_its_decision() -> None:
    expert = load_policy("expert")
    ranked = expert.ranked(scene([obj("a", 0.5, 0), obj("c", 0.7, 0)], UNCHANGED[1]))
    assert [d.pair for d in ranked] == [("a", "g0"), ("a", "g1"), ("c", "g0"), ("c", "g1")]


def test_gat_escapes_a_covered_block_on_a_10_block_pyramid() -> None:
    # Seed 770014 of the evaluation: GAT picked a covered block until the budget ran out.
    policy = load_policy(str(REPO / "checkpoints" / "gat.pt"))
    request = EpisodeRequest(episode_id="p", task="pyramid", blocks=10, seed=770014)
    record = run_episode(policy, request)
    assert record.success
    recoveries = [s.action for s in record.steps if s.action.recovery]
    assert recoveries and all(a.rank > 0 for a in recoveries)


def test_actions_carry_rank_and_recovery_and_old_logs_still_decode() -> None:
    action = Decision("a", "g0").to_action(scene(*UNCHANGED), 3, "p", 1.0, 2, "no_progress")
    decoded = Action.decode(action.encode())
    assert (decoded.rank, decoded.recovery) == (2, "no_progress")
    fields = json.loads(action.encode())
    del fields["rank"], fields["recovery"]
    old = Action.decode(json.dumps(fields).encode())
    assert (old.rank, old.recovery) == (0, None)


class NeverPassOver(ProgressMonitor):
    def verdict(self, scene: Scene) -> Verdict:
        return Verdict()


@pytest.mark.parametrize(("task", "blocks", "stacks"), [("pyramid", 10, 1), ("box-pack", 3, 1)])
def test_episodes_that_succeed_without_recovery_take_the_same_decisions_with_it(
    task: str, blocks: int, stacks: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    policy = load_policy(str(REPO / "checkpoints" / "gat.pt"))
    requests = [
        EpisodeRequest(episode_id="e", task=task, blocks=blocks, stacks=stacks, seed=seed)
        for seed in range(770011, 770017)
    ]
    with_recovery = [run_episode(policy, r) for r in requests]
    monkeypatch.setattr(
        episode_loop,
        "DecisionMaker",
        lambda policy, clock: DecisionMaker(policy, clock=clock, progress=NeverPassOver()),
    )
    without = [run_episode(policy, r) for r in requests]
    assert any(r.success for r in without)
    for a, b in zip(without, with_recovery, strict=True):
        if a.success:
            assert b.success
            assert [s.action.to_builtins(exclude={"stamp"}) for s in a.steps] == [
                s.action.to_builtins(exclude={"stamp"}) for s in b.steps
            ]
    assert sum(r.success for r in with_recovery) >= sum(r.success for r in without)
