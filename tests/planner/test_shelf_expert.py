"""The shelf's expert: every size of shelf filled, back slots first, one pick per slot."""

from __future__ import annotations

import pytest

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.family import FAMILIES, family_of
from manigraph_planner.policies import load_policy
from manigraph_shared.messages import EpisodeRequest
from manigraph_shelf.shelf_geometry import BACK, ROW_ATTRIBUTE


@pytest.mark.parametrize("objects", [2, 4, 6, 8, 12, 14, 18])
def test_the_expert_fills_every_shelf_in_one_pick_per_slot(objects: int) -> None:
    for seed in (53910, 53911):
        request = EpisodeRequest(episode_id="e", task="shelf", objects=objects, seed=seed)
        record = run_episode(load_policy("shelf-expert"), request)
        assert record.success, (objects, seed, record.end.reason)
        assert all(step.ok for step in record.steps)
        assert len(record.steps) == objects


def test_the_expert_takes_back_slots_before_front_slots() -> None:
    request = EpisodeRequest(episode_id="e", task="shelf", objects=8, seed=53912)
    record = run_episode(load_policy("shelf-expert"), request)
    rows = [step.scene.goal(step.action.goal_id).attributes[ROW_ATTRIBUTE] for step in record.steps]
    assert rows == [BACK] * 4 + ["front"] * 4


def test_a_shelf_scene_is_the_shelf_familys_and_demonstrated_by_its_expert() -> None:
    request = EpisodeRequest(episode_id="e", task="shelf", objects=4, seed=53913)
    record = run_episode(load_policy("shelf-expert"), request)
    assert family_of(record.steps[0].scene).name == "shelf"
    assert FAMILIES["shelf"].expert(request).decide(record.steps[0].scene) is not None


def test_after_a_refusal_the_expert_offers_the_other_blocks_then_the_other_slots() -> None:
    """A refused pick (no grasp for one block where it lies) must not end the episode: the
    ranking holds every loose block for the drawn slot, then the other free back slots, and
    never a front slot while a back one is free."""
    request = EpisodeRequest(episode_id="e", task="shelf", objects=6, seed=53914)
    scene = run_episode(load_policy("shelf-expert"), request).steps[0].scene
    expert = load_policy("shelf-expert")
    ranked = expert.ranked(scene)
    assert ranked[0] == expert.decide(scene)
    loose = {obj.id for obj in scene.objects if not obj.filled}
    backs = {g.id for g in scene.goals if g.attributes[ROW_ATTRIBUTE] == BACK and not g.filled}
    assert len(ranked) == len(loose) * len(backs) == len(set(ranked))
    assert {d.goal_id for d in ranked} == backs
    first_slot = [d for d in ranked if d.goal_id == ranked[0].goal_id]
    assert ranked[: len(loose)] == first_slot and {d.object_id for d in first_slot} == loose
