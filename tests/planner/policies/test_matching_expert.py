"""The expert on goals that say what they accept: matching, support order, moving out."""

from __future__ import annotations

from typing import Any

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_planner.policies.base import Decision
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

EXPERT = ExpertPolicy()


def block(
    name: str, x: float, y: float = -0.2, z: float | None = None, size: float = 0.04, **attrs: Any
) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=y, z=size / 2 if z is None else z),
        size=Vector3(x=size, y=size, z=size),
        attributes=attrs,
    )


def goal(name: str, x: float, y: float = 0.2, z: float = 0.02, **accepts: Any) -> SceneGoal:
    return SceneGoal(id=name, category="block", position=Vector3(x=x, y=y, z=z), accepts=accepts)


def scene(objects: list[SceneObject], goals: list[SceneGoal]) -> Scene:
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


def test_size_rule_sends_each_block_to_a_goal_of_its_size() -> None:
    small, large = [0.03] * 3, [0.07] * 3
    objects = [block("big", 0.4, size=0.07), block("small", 0.5, size=0.03)]
    goals = [goal("g_large", 0.4, z=0.035, size=large), goal("g_small", 0.6, z=0.015, size=small)]
    first = EXPERT.decide(scene(objects, goals))
    assert first == Decision("small", "g_small")  # the lowest goal first
    done = scene([block("big", 0.4, size=0.07), block("small", 0.6, 0.2, size=0.03)], goals)
    assert EXPERT.decide(done) == Decision("big", "g_large")


def test_colour_rule_never_sends_a_block_to_a_goal_of_another_colour() -> None:
    objects = [block("b0", 0.4, colour="blue"), block("b1", 0.5, colour="red")]
    goals = [goal("red_slot", 0.4, colour="red"), goal("blue_slot", 0.6, colour="blue")]
    ranked = EXPERT.ranked(scene(objects, goals))
    assert ranked[0] == Decision("b0", "blue_slot")  # blue_slot: equal height, smaller id
    assert set(ranked) == {Decision("b0", "blue_slot"), Decision("b1", "red_slot")}


def test_id_rule_and_a_matching_keep_the_object_another_goal_needs() -> None:
    # slot_a takes any block, slot_b only part_1: part_1 comes first by id, but sending it to
    # slot_a (the first goal) would strand slot_b.
    objects = [block("part_1", 0.4), block("part_2", 0.5)]
    goals = [goal("slot_a", 0.5), goal("slot_b", 0.6, id="part_1")]
    assert EXPERT.decide(scene(objects, goals)) == Decision("part_2", "slot_a")
    assert Decision("part_1", "slot_a") not in EXPERT.ranked(scene(objects, goals))


def test_support_order_fills_the_bottom_goal_first_and_never_over_an_empty_one() -> None:
    objects = [block("r0", 0.4, colour="red"), block("r1", 0.5, colour="red")]
    goals = [
        goal("top", 0.6, z=0.06, colour="red"),
        goal("bottom", 0.6, z=0.02, colour="red"),
    ]
    assert EXPERT.decide(scene(objects, goals)).goal_id == "bottom"  # type: ignore[union-attr]
    # Only the top goal accepts what is left, but the bottom one is still empty: wait.
    blue = [block("b0", 0.4, colour="blue")]
    stranded = [goal("top", 0.6, z=0.06, colour="blue"), goal("bottom", 0.6, z=0.02, colour="red")]
    assert EXPERT.decide(scene(blue, stranded)) is None


def test_a_covered_block_is_never_picked() -> None:
    objects = [block("under", 0.4, colour="red"), block("over", 0.4, z=0.06, colour="blue")]
    goals = [goal("red_slot", 0.5, colour="red"), goal("blue_slot", 0.6, colour="blue")]
    assert EXPERT.decide(scene(objects, goals)) == Decision("over", "blue_slot")


def test_an_object_in_a_goal_that_refuses_it_is_moved_out_to_one_that_accepts_it() -> None:
    objects = [block("blue_one", 0.4, 0.2, colour="blue"), block("red_one", 0.7, colour="red")]
    goals = [goal("red_slot", 0.4, colour="red"), goal("blue_slot", 0.6, colour="blue")]
    # blue_slot is free and blue_one may go there: the fill rule moves it out.
    assert EXPERT.decide(scene(objects, goals)) == Decision("blue_one", "blue_slot")
    # Then red_slot is free for red_one.
    moved = [block("blue_one", 0.6, 0.2, colour="blue"), block("red_one", 0.7, colour="red")]
    assert EXPERT.decide(scene(moved, goals)) == Decision("red_one", "red_slot")


def test_spares_no_goal_accepts_are_left_alone_and_done_goals_end_the_episode() -> None:
    goals = [goal("red_slot", 0.4, colour="red")]
    objects = [block("red_one", 0.4, 0.2, colour="red"), block("spare", 0.5, colour="blue")]
    assert EXPERT.decide(scene(objects, goals)) is None
    assert EXPERT.ranked(scene(objects, goals)) == []


def test_an_unsatisfiable_scene_is_a_no_op() -> None:
    objects = [block("b0", 0.4, colour="blue"), block("b1", 0.5, colour="blue")]
    goals = [goal("red_slot", 0.4, colour="red")]
    assert EXPERT.decide(scene(objects, goals)) is None


def test_without_accepts_the_paper_rules_decide_as_before() -> None:
    objects = [block("b0", 0.4), block("b1", 0.4, z=0.06)]
    goals = [goal("g1", 0.6, z=0.06), goal("g0", 0.6)]
    assert EXPERT.decide(scene(objects, goals)) == Decision("b1", "g0")
