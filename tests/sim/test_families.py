"""Task families (``manigraph_sim.family``): each one registered unit that lays out its
tasks from its own options, decides its own success and refuses another family's field (that
no sim module asks which family a layout is: ``tests/shared/test_family_boundary.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from manigraph_blocks.sim.options import BlockOptions
from manigraph_dishwasher.sim.model import DishwasherLayout, allowed
from manigraph_dishwasher.sim.options import DishwasherOptions
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.family import FAMILIES, family_of
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.tasks import TASKS
from manigraph_sim.world_model import Layout
from manigraph_testkit.families import families_with


def request(task: str, **fields: object) -> EpisodeRequest:
    return EpisodeRequest(episode_id="e", task=task, seed=2, **fields)  # type: ignore[arg-type]


def test_both_families_are_registered_with_their_options() -> None:
    assert list(FAMILIES) == families_with("sim")
    assert {"blocks", "dishwasher"} <= set(FAMILIES)
    assert FAMILIES.entry("blocks").options is BlockOptions
    assert FAMILIES.entry("dishwasher").options is DishwasherOptions
    assert FAMILIES["dishwasher"].layout_type is DishwasherLayout
    assert FAMILIES["blocks"].layout_type is Layout


def test_every_task_belongs_to_exactly_one_family() -> None:
    for task in TASKS:
        owners = [name for name, family in FAMILIES.items() if task in family.tasks]
        assert len(owners) == 1, (task, owners)
        assert family_of(request(task)).name == owners[0]
    assert family_of(request("file", task_file="")).name == "blocks"


def test_the_block_family_evaluates_its_own_success() -> None:
    family = FAMILIES["blocks"]
    layout = family.task(request("stack", blocks=3)).layout(np.random.default_rng(0))
    world = family.geometric_world(layout, 0.01)
    start = world.evaluate()
    assert (start.filled, start.total, start.success) == (0, 3, False)
    bottom = min(layout.goals, key=lambda g: g.position[2])
    body = layout.bodies[0]
    body.position = bottom.position.copy()  # one block where the lowest goal is
    middle = family.evaluate(layout, world)
    assert middle.filled_goals == {bottom.id} and not middle.success
    lowest_first = sorted(layout.goals, key=lambda g: g.position[2])
    for body, goal in zip(layout.bodies, lowest_first, strict=True):
        body.position = goal.position.copy()
    end = world.evaluate()
    assert (end.filled, end.total, end.success, end.wrong_object) == (3, 3, True, 0)


def test_the_dishwasher_family_evaluates_its_own_success() -> None:
    """Its goals are the dishes (each loaded as preferred) and the racks (pushed in)."""
    family = FAMILIES["dishwasher"]
    task = family.task(request("dishwasher", objects=4, options={"preference": "top-bottom"}))
    layout = task.layout(np.random.default_rng(0))
    world = family.geometric_world(layout, 0.01)
    start = world.evaluate()
    assert start.total == 4 + 2 and start.filled_goals == {"rack_top", "rack_bottom"}
    assert not start.success
    dishes = world.dishes.values()  # type: ignore[attr-defined]
    free = list(world.slots.values())  # type: ignore[attr-defined]
    for dish in dishes:
        slot = next(s for s in free if allowed(layout.preference, dish.kind, s))
        free.remove(slot)
        dish.slot, dish.orientation = slot.id, slot.orientation
    end = world.evaluate()
    assert end.success and end.filled == end.total == 6
    world.racks["rack_top"].open = True  # type: ignore[attr-defined]
    assert not world.evaluate().success  # a rack left out is not loaded


def test_the_backend_ends_in_success_by_the_family_rule() -> None:
    sim = GeometricBackend()
    sim.reset(request("dishwasher", objects=2), 0.0)
    assert sim.required == {"plate_0", "bowl_0", "rack_top", "rack_bottom"}
    assert sim.required_filled() == 2  # both racks start pushed in


@pytest.mark.parametrize(
    ("task", "fields", "named"),
    [
        ("stack", {"objects": 4}, "family.objects"),
        ("pyramid", {"options": {"preference": "left-right"}}, "family.preference"),
        ("box-pack", {"objects": 2, "options": {"preference": "top-bottom"}}, "family.objects"),
    ],
)
def test_a_request_field_of_another_family_is_refused(
    task: str, fields: dict[str, object], named: str
) -> None:
    with pytest.raises(ConfigError, match=rf"^{named}: not an option of family 'blocks'") as err:
        GeometricBackend().reset(request(task, **fields), 0.0)
    assert err.value.field == named


def test_a_request_naming_its_family_is_checked_against_the_task() -> None:
    backend = GeometricBackend()
    backend.reset(request("dishwasher", family="dishwasher", objects=2), 0.0)
    assert backend.scene(1.0) is not None
    with pytest.raises(ConfigError, match=r"^family: 'stack' is a task of blocks, not of dish"):
        backend.reset(request("stack", family="dishwasher"), 0.0)
    with pytest.raises(ConfigError, match=r"^family"):
        backend.reset(request("stack", family="no_such_family"), 0.0)


def test_a_family_option_may_not_shadow_a_field_of_the_request() -> None:
    with pytest.raises(ConfigError, match=r"^options\.seed: is a field of the request"):
        GeometricBackend().reset(request("stack", options={"seed": 3.0}), 0.0)


def test_a_task_file_request_with_another_family_field_is_refused() -> None:
    text = (Path(__file__).resolve().parents[2] / "examples/tasks/size-sort.toml").read_text()
    with pytest.raises(ConfigError, match=r"family\.objects"):
        GeometricBackend().reset(request("file", task_file=text, objects=3), 0.0)


def test_options_of_another_family_are_refused_by_name() -> None:
    with pytest.raises(ConfigError, match=r"family\.blocks: not an option of family 'dishwasher'"):
        FAMILIES.options("dishwasher", {"blocks": 3})
    assert FAMILIES.options("dishwasher", {"objects": 3}) == DishwasherOptions(objects=3)


def test_the_dishwasher_ignores_the_block_counts_every_request_carries() -> None:
    """``blocks`` and ``stacks`` have defaults in the contract: a demo protocol sends them
    with every task, the dishwasher's too."""
    event = GeometricBackend().reset(request("dishwasher", blocks=3, objects=2), 0.0)
    assert event.goals_total == 2 + 2


def test_an_unknown_task_still_names_the_registered_ones() -> None:
    with pytest.raises(ConfigError, match=r"task: 'tower' is not one of: .*stack"):
        GeometricBackend().reset(request("tower"), 0.0)
