"""The dishwasher world: its rules, its layouts, and the expert that solves it."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_dishwasher.sim.dishwasher_world import DishwasherWorld
from manigraph_dishwasher.sim.model import BOTTOM, TOP, Preference
from manigraph_dishwasher.sim.options import DishwasherOptions
from manigraph_dishwasher.sim.scene import dishwasher_scene
from manigraph_lab.episode_loop import run_episode
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import SkillError, TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_shared.orientations import UPRIGHT, UPSIDE_DOWN
from manigraph_sim.tasks import get_task


def world(objects: int = 4, preference: str = "top-bottom", seed: int = 0) -> DishwasherWorld:
    task = get_task("dishwasher", DishwasherOptions(objects=objects, preference=preference))
    return DishwasherWorld(task.layout(np.random.default_rng(seed)))


def slot_position(w: DishwasherWorld, slot_id: str) -> np.ndarray:
    return w.slot_position(w.slots[slot_id])


def test_a_closed_rack_is_refused_and_the_dish_stays_where_it_was() -> None:
    w = world()
    start = w.dishes["bowl_0"].position.copy()
    w.pick("bowl_0")
    with pytest.raises(SkillError) as refused:
        w.place("bowl_0", slot_position(w, "top_bowl_00"), UPSIDE_DOWN)
    assert refused.value.reason == "rack_closed"
    assert w.held is None and w.dishes["bowl_0"].slot is None
    assert np.allclose(w.dishes["bowl_0"].position, start)


def test_the_bottom_rack_is_refused_while_the_top_one_is_out() -> None:
    w = world()
    w.toggle(BOTTOM)
    w.toggle(TOP)
    w.pick("plate_0")
    with pytest.raises(SkillError) as refused:
        w.place("plate_0", slot_position(w, "bottom_plate_00"), UPRIGHT)
    assert refused.value.reason == "top_rack_open"
    w.toggle(TOP)
    w.pick("plate_0")
    w.place("plate_0", slot_position(w, "bottom_plate_00"), UPRIGHT)
    assert w.dishes["plate_0"].slot == "bottom_plate_00"


def test_a_slot_holds_one_dish_of_its_kind() -> None:
    w = world()
    w.toggle(TOP)
    w.pick("bowl_0")
    w.place("bowl_0", slot_position(w, "top_bowl_03"), UPSIDE_DOWN)
    w.pick("bowl_1")
    with pytest.raises(SkillError, match="top_bowl_03") as taken:
        w.place("bowl_1", slot_position(w, "top_bowl_03"), UPSIDE_DOWN)
    assert taken.value.reason == "slot_taken"
    w.pick("plate_0")
    with pytest.raises(SkillError) as wrong:
        w.place("plate_0", slot_position(w, "top_bowl_04"), UPRIGHT)
    assert wrong.value.reason == "wrong_slot"


def test_dishes_travel_with_their_rack_and_success_needs_orientation_and_racks_in() -> None:
    w = world(objects=1, preference="left-right")  # one plate
    w.toggle(TOP)
    w.pick("plate_0")
    w.place("plate_0", slot_position(w, "top_plate_00"), UPSIDE_DOWN)  # wrong way round
    assert w.loaded() == 0
    w.pick("plate_0")
    w.place("plate_0", slot_position(w, "top_plate_00"), UPRIGHT)
    assert w.loaded() == 1 and not w.done()  # the top rack is still out
    out = w.dishes["plate_0"].position.copy()
    w.toggle(TOP)
    assert w.dishes["plate_0"].position[0] > out[0] + 0.1
    assert w.done()


def test_a_dish_standing_the_wrong_way_round_is_not_filled_but_its_slot_is() -> None:
    """A physical turn-over once left a bowl upright in its slot, reported as standing
    there: the policy, which moves no standing dish, toggled racks until the step budget
    was spent. It is a dish still to load; its slot holds it, so it goes into another."""
    w = world()
    w.toggle(TOP)
    w.pick("bowl_0")
    w.place("bowl_0", slot_position(w, "top_bowl_00"), UPRIGHT)
    scene = dishwasher_scene(w, "e", 1.0, 0, ended=False)
    assert not scene.object("bowl_0").filled and scene.goal("top_bowl_00").filled
    w.pick("bowl_0")
    w.place("bowl_0", slot_position(w, "top_bowl_01"), UPSIDE_DOWN)
    scene = dishwasher_scene(w, "e", 1.0, 0, ended=False)
    assert scene.object("bowl_0").filled and scene.goal("top_bowl_01").filled
    assert not scene.goal("top_bowl_00").filled


def test_a_right_side_plate_breaks_the_left_right_preference() -> None:
    w = world(objects=1, preference="left-right")
    w.toggle(TOP)
    w.pick("plate_0")
    w.place("plate_0", slot_position(w, "top_plate_11"), UPRIGHT)  # y > 0: the bowls' side
    w.toggle(TOP)
    assert w.loaded() == 0 and not w.done()


def test_layouts_are_seeded_and_options_are_checked() -> None:
    a, b = world(seed=3), world(seed=3)
    assert all(np.array_equal(a.dishes[k].position, b.dishes[k].position) for k in a.dishes)
    assert {d.kind for d in a.dishes.values()} == {"plate", "bowl"}
    with pytest.raises(TaskError, match="preference"):
        get_task("dishwasher", DishwasherOptions(objects=4, preference="sideways"))
    with pytest.raises(TaskError, match="objects"):
        get_task("dishwasher", DishwasherOptions(objects=13))
    assert Preference.parse(None) is Preference.TOP_BOTTOM


@pytest.mark.parametrize("preference", ["top-bottom", "left-right"])
@pytest.mark.parametrize("objects", [1, 5, 8, 12])
def test_the_expert_solves_every_preference(preference: str, objects: int) -> None:
    expert = load_policy(f"dishwasher-{preference}")
    for seed in range(3):
        request = EpisodeRequest(
            episode_id=f"e{seed}",
            task="dishwasher",
            objects=objects,
            options={"preference": preference},
            seed=seed,
        )
        record = run_episode(expert, request)
        assert record.success, (seed, record.end.reason)
        assert all(step.ok for step in record.steps)
        assert record.end.goals_filled == record.end.goals_total == objects + 2


def test_the_other_preferences_expert_fails() -> None:
    request = EpisodeRequest(
        episode_id="e", task="dishwasher", objects=4, options={"preference": "left-right"}
    )
    record = run_episode(load_policy("dishwasher-top-bottom"), request)
    assert not record.success
