"""Each dishwasher rule is written once, in the family's common modules, and every part that
reads it reads the same answer: the sim's judge and the expert agree on every slot of a real
layout, and the learned policy's rack test agrees with the skills' refusal."""

from __future__ import annotations

import itertools
from typing import Any

import pytest

from manigraph_dishwasher.planner.expert import preferred
from manigraph_dishwasher.preference import Preference, allows, preferred_rack
from manigraph_dishwasher.rules import (
    BOTTOM_RACK,
    TOP_RACK,
    check_rack_usable,
    is_dishwasher_scene,
    rack_refusal,
    rack_usable,
)
from manigraph_dishwasher.sim.model import allowed
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import EpisodeRequest, ObjectCategory, Scene
from manigraph_sim.geometric.backend import GeometricBackend


def first_scene(task: str, **request: Any) -> tuple[GeometricBackend, Scene]:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, **request), 0.0)
    return backend, backend.scene(1.0)


@pytest.mark.parametrize("preference", list(Preference))
def test_the_judge_and_the_expert_read_one_preference(preference: Preference) -> None:
    backend, scene = first_scene("dishwasher", objects=8, options={"preference": preference.value})
    world = backend.world
    assert world.preference is preference  # type: ignore[attr-defined]
    slots = world.slots  # type: ignore[attr-defined]
    verdicts = set()
    for kind, goal in itertools.product((ObjectCategory.PLATE, ObjectCategory.BOWL), scene.goals):
        judge = allowed(preference, kind.value, slots[goal.id])
        assert preferred(preference.value, kind, goal) == judge, (preference, kind, goal.id)
        verdicts.add(judge)
    assert verdicts == {True, False}  # the rule lets some slots and refuses others


def test_the_preference_puts_each_dish_in_one_rack_and_side() -> None:
    assert preferred_rack(Preference.TOP_BOTTOM, "bowl") == TOP_RACK
    assert preferred_rack(Preference.TOP_BOTTOM, "plate") == BOTTOM_RACK
    assert preferred_rack(Preference.LEFT_RIGHT, "plate") == TOP_RACK
    assert allows(Preference.LEFT_RIGHT, "plate", "plate", TOP_RACK, left=True)
    assert not allows(Preference.LEFT_RIGHT, "plate", "plate", TOP_RACK, left=False)
    assert not allows(Preference.TOP_BOTTOM, "plate", "bowl", BOTTOM_RACK, left=True)
    assert allows(Preference.TOP_BOTTOM, "bowl", "bowl", TOP_RACK, left=False)


@pytest.mark.parametrize("top_open, bottom_open", list(itertools.product((False, True), repeat=2)))
def test_the_policy_and_the_skills_read_one_rack_rule(top_open: bool, bottom_open: bool) -> None:
    racks = {TOP_RACK: top_open, BOTTOM_RACK: bottom_open}
    for rack in racks:
        refusal = rack_refusal(rack, racks)
        assert rack_usable(rack, racks) == (refusal is None)
        if refusal is None:
            check_rack_usable(rack, racks)
        else:
            with pytest.raises(SkillError) as raised:
                check_rack_usable(rack, racks)
            assert raised.value.reason == refusal.reason
    assert rack_usable(TOP_RACK, racks) == top_open
    assert rack_usable(BOTTOM_RACK, racks) == (bottom_open and not top_open)


def test_a_dishwasher_scene_is_the_one_with_racks() -> None:
    assert is_dishwasher_scene(first_scene("dishwasher", objects=4)[1])
    assert not is_dishwasher_scene(first_scene("box-pack", blocks=3)[1])
