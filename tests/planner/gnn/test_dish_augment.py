"""Dishwasher demonstrations shown with more dishes than they held: the decision must not change."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
import torch

from manigraph_lab.demos import DemoProtocol, record_demos
from manigraph_planner.gnn.dish_features import DISH_FEATURE_SPEC
from manigraph_planner.policies.dishwasher_expert import dishwasher_expert
from manigraph_planner.training.dish_augment import DishSample, add_dishes, counter_dishes
from manigraph_planner.training.dishwasher import DishDemos, load_dish_demonstrations

NAMES = DISH_FEATURE_SPEC.names
FILLED, OPEN, X, Y, Z = (NAMES.index(n) for n in ("filled", "open", "x", "y", "z"))
PLACE = 2  # TRAY_ACTIONS index of "none"


@pytest.fixture(scope="module", params=["top-bottom", "left-right"])
def demos(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> DishDemos:
    path: Path = tmp_path_factory.mktemp("grow") / "demos.mcap"
    protocol = DemoProtocol(("dishwasher",), (4,), 2, 0, 6, request.param)
    record_demos(dishwasher_expert(request.param), protocol, path)
    return load_dish_demonstrations([path])


def waiting(sample: DishSample, kind: int) -> int:
    dishes = sample.x[: sample.num_objects]
    return int(((dishes[:, kind] == 1) & (dishes[:, FILLED] == 0)).sum())


def pushes_a_rack_in(sample: DishSample) -> bool:
    if sample.tray == PLACE:
        return False
    return bool(sample.x[sample.num_objects + sample.num_goals + sample.tray, OPEN] == 1)


def test_added_dishes_leave_every_demonstrated_decision_as_it_was(demos: DishDemos) -> None:
    pool = counter_dishes(demos.samples)
    rng = random.Random(0)
    grown = 0
    for sample in demos.samples:
        for _ in range(5):
            copy = add_dishes(sample, pool, rng)
            k, m = copy.num_objects, copy.num_goals
            assert (
                copy.x.shape[0] == k + m + 2
                and m == sample.num_goals
                and k <= sample.num_objects + 3
            )
            grown += k > sample.num_objects
            # The demonstrated dishes, slots' kinds and racks are all still there.
            assert torch.equal(copy.x[: sample.num_objects], sample.x[: sample.num_objects])
            assert torch.equal(copy.x[k + m :], sample.x[sample.num_objects + m :])
            slots, dishes = copy.x[k : k + m], copy.x[:k]
            # Each dish in a slot fills exactly the slot it stands in.
            assert int(slots[:, FILLED].sum()) == int(dishes[:, FILLED].sum())
            for dish in dishes[dishes[:, FILLED] == 1]:
                at = (slots[:, X : Z + 1] - dish[X : Z + 1]).abs().amax(dim=1) < 1e-3
                assert int(at.sum()) == 1 and slots[at, FILLED].item() == 1
            if sample.tray == PLACE:  # the same dish into the same slot, which stays free
                assert copy.object_index == sample.object_index
                assert slots[copy.goal_index, FILLED] == 0
            if pushes_a_rack_in(sample):  # nothing more left to load for that rack
                assert waiting(copy, 0) == waiting(sample, 0)
                assert waiting(copy, 1) == waiting(sample, 1)
            # Dishes waiting on the counter never share a place.
            counter = dishes[dishes[:, FILLED] == 0][:, X : Y + 1]
            gaps = (counter.unsqueeze(0) - counter.unsqueeze(1)).abs().amax(dim=-1)
            assert bool((gaps + torch.eye(len(counter)) > 0.05).all())
    assert grown > len(demos.samples)


def test_an_added_dish_stands_where_its_kind_already_stands(demos: DishDemos) -> None:
    """Same rack and row (x, z) and same side (sign of y) as a demonstrated dish of its kind:
    the preference, read off the demonstration, never a slot it does not allow."""
    pool = counter_dishes(demos.samples)
    rng = random.Random(1)
    for sample in demos.samples:
        copy = add_dishes(sample, pool, rng, most=3)
        k0, k = sample.num_objects, copy.num_objects
        for dish in copy.x[k0:k]:
            if dish[FILLED] == 0:
                continue
            kind = int(dish[:2].argmax())
            before = sample.x[:k0]
            mates = before[(before[:, kind] == 1) & (before[:, FILLED] == 1)]
            same_row = (mates[:, [X, Z]] - dish[[X, Z]]).abs().amax(dim=1) < 1e-3
            same_side = (mates[:, Y] > 0) == (dish[Y] > 0)
            assert bool((same_row & same_side).any())
