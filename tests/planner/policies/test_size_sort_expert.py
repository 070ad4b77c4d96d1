"""The size-sort task's expert (docs/tasks/size-sort.md): fitting pairs only, nearest first,
and every episode sorted in one move per block."""

from __future__ import annotations

import pytest

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.policies import POLICIES
from manigraph_planner.policies.base import expert_for
from manigraph_planner.policies.size_sort_expert import SizeSortExpert
from manigraph_shared.messages import EpisodeRequest, Scene, SceneGoal, SceneObject, Vector3


def cube(name: str, side: float, x: float, y: float, **flags: bool) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=y, z=side / 2),
        size=Vector3(x=side, y=side, z=side),
        **flags,
    )


def goal(name: str, side: float, x: float, y: float, **flags: bool) -> SceneGoal:
    return SceneGoal(id=name, category="block", position=Vector3(x=x, y=y, z=side / 2), **flags)


def scene(objects: list[SceneObject], goals: list[SceneGoal]) -> Scene:
    return Scene(episode_id="e", stamp=0.0, sequence=0, objects=objects, goals=goals)


def test_it_is_size_sorts_registered_expert_and_a_policy_of_its_own() -> None:
    assert isinstance(expert_for("size-sort"), SizeSortExpert)
    assert POLICIES["size-sort-expert"] is SizeSortExpert


def test_it_only_pairs_a_block_with_a_goal_of_its_size_nearest_first() -> None:
    seen = scene(
        [cube("big", 0.06, 0.30, 0.0), cube("small", 0.03, 0.30, 0.2)],
        [goal("small_goal", 0.03, 0.55, 0.0), goal("large_goal", 0.06, 0.55, 0.25)],
    )
    ranked = SizeSortExpert().ranked(seen)
    # The small block is nearer the large goal and the large block nearer the small goal:
    # neither of those pairs is offered.
    assert [d.pair for d in ranked] == [("small", "small_goal"), ("big", "large_goal")]
    assert SizeSortExpert().decide(seen) == ranked[0]


def test_blocks_and_goals_already_filled_are_done() -> None:
    seen = scene(
        [cube("a", 0.03, 0.55, 0.0, filled=True), cube("b", 0.03, 0.30, 0.0)],
        [goal("g0", 0.03, 0.55, 0.0, filled=True), goal("g1", 0.03, 0.55, 0.05)],
    )
    assert [d.pair for d in SizeSortExpert().ranked(seen)] == [("b", "g1")]
    done = scene(
        [cube("a", 0.03, 0.55, 0.0, filled=True)], [goal("g0", 0.03, 0.55, 0.0, filled=True)]
    )
    assert SizeSortExpert().decide(done) is None


@pytest.mark.parametrize("blocks", range(2, 9))
def test_it_sorts_every_episode_in_one_move_per_block(blocks: int) -> None:
    for seed in range(10):
        request = EpisodeRequest(
            episode_id=f"size-sort-{blocks}-{seed}", task="size-sort", blocks=blocks, seed=seed
        )
        record = run_episode(SizeSortExpert(), request)
        assert record.success, (blocks, seed, record.end.reason)
        assert len(record.steps) == blocks
