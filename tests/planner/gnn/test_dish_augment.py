"""Dishwasher demonstrations shown with more dishes than they held: the decision must not change."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
import torch

from manigraph_dishwasher.fixtures import Rack, TrayAction
from manigraph_dishwasher.planner.expert import dishwasher_expert, preferred
from manigraph_dishwasher.planner.features import DISH_FEATURE_SPEC, TRAY_ACTIONS
from manigraph_dishwasher.training.augment import DishSample, add_dishes, counter_dishes
from manigraph_dishwasher.training.loop import DishDemos, load_dish_demonstrations
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_shared.orientations import ORIENTATIONS

NAMES = DISH_FEATURE_SPEC.names
FILLED, OPEN, X, Y, Z = (NAMES.index(n) for n in ("filled", "open", "x", "y", "z"))
PLACE = 2  # TRAY_ACTIONS index of "none"


@pytest.fixture(scope="module", params=["top-bottom", "left-right"])
def preference(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def demos(preference: str, tmp_path_factory: pytest.TempPathFactory) -> DishDemos:
    path: Path = tmp_path_factory.mktemp("grow") / "demos.mcap"
    protocol = DemoProtocol(("dishwasher",), (4,), 2, 0, 6, preference)
    record_demos(dishwasher_expert(preference), protocol, path)
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


def as_scene(sample: DishSample) -> Scene:
    """Node rows back into a Scene the expert can read. Dish ids follow the node order (so an
    added dish's sorts after the demonstrated ones', as a dish brought in later would),
    except that a placement's dish gets the smallest: the expert places the smallest id of
    the dishes its open rack takes, and the graph holds no ids, so it picks the labelled dish
    exactly when that dish is one it would load now. Slot ``s<j>`` is the ``j``-th slot node;
    its rack is the one whose handle is nearest in height."""
    k, m = sample.num_objects, sample.num_goals
    racks = sample.x[k + m :]
    heights = {
        rack: float(racks[racks[:, NAMES.index(f"is-{rack.replace('_', '-')}")] == 1, Z][0])
        for rack in ("rack_top", "rack_bottom")
    }

    def pose(row: torch.Tensor) -> dict[str, object]:
        orientation = ORIENTATIONS[int(row[NAMES.index("orientation-0") :].argmax())]
        position = Vector3(x=float(row[X]), y=float(row[Y]), z=float(row[Z]))
        return {"position": position, "orientation": orientation, "filled": bool(row[FILLED])}

    kinds = ("plate", "bowl")
    objects = [
        SceneObject(
            id="d00" if sample.tray == PLACE and i == sample.object_index else f"d{i + 1:02d}",
            category=kinds[int(row[:2].argmax())],
            size=Vector3(x=0.08, y=0.08, z=0.03),
            **pose(row),  # type: ignore[arg-type]
        )
        for i, row in enumerate(sample.x[:k])
    ]
    goals = [
        SceneGoal(
            id=f"s{j:02d}",
            category=kinds[int(row[2:4].argmax())],
            fixture=min(heights, key=lambda rack: abs(heights[rack] - float(row[Z]))),
            **pose(row),  # type: ignore[arg-type]
        )
        for j, row in enumerate(sample.x[k : k + m])
    ]
    shelves = [
        Rack(
            id=rack,
            position=Vector3(x=float(row[X]), y=float(row[Y]), z=float(row[Z])),
            open=bool(row[OPEN]),
        ).fixture()
        for rack, row in zip(("rack_top", "rack_bottom"), racks, strict=True)
    ]
    return Scene(
        episode_id="aug", stamp=1.0, sequence=0, objects=objects, goals=goals, fixtures=shelves
    )


def assert_expert_agrees(sample: DishSample, preference: str) -> None:
    """The expert takes the labelled decision: the same tray action; for a placement, the
    labelled dish (:func:`as_scene`), in the labelled orientation, into a free slot it
    prefers, as the labelled one is (it draws which by a hash of ids the graph does not
    hold)."""
    scene = as_scene(sample)
    decision = dishwasher_expert(preference).decide(scene)
    assert decision is not None
    assert TRAY_ACTIONS.index(TrayAction.of(decision)) == sample.tray
    if sample.tray != PLACE:
        return
    label = scene.objects[sample.object_index]
    assert decision.object_id == label.id
    slot = scene.goals[sample.goal_index]
    assert preferred(preference, label.category, slot) and not slot.filled
    assert decision.orientation_index == sample.orientation


def test_the_expert_agrees_with_its_own_demonstrations(demos: DishDemos, preference: str) -> None:
    for sample in demos.samples:
        assert_expert_agrees(sample, preference)


def test_the_expert_agrees_with_every_grown_copy(demos: DishDemos, preference: str) -> None:
    """Checked by the expert itself: more dishes, waiting and loaded, never change its
    decision (the grown copies are those ``DishTrainConfig.grow_copies`` trains on)."""
    pool = counter_dishes(demos.samples)
    rng = random.Random(2)
    for sample in demos.samples:
        for _ in range(5):
            assert_expert_agrees(add_dishes(sample, pool, rng), preference)
