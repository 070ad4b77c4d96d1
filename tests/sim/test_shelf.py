"""The shelf world: its slots, its success rule and the front slot that blocks the back one."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest
import torch

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.family import FAMILIES
from manigraph_planner.gnn.features import FeatureSpec, scene_to_graph
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.errors import SkillError, TaskError
from manigraph_shared.messages import EpisodeRequest, Scene
from manigraph_shelf.cupboard import BOARD, WALL
from manigraph_shelf.shelf_geometry import BACK, FRONT, ROW_ATTRIBUTE, levels_for, slots_for
from manigraph_shelf.sim.family import ShelfFamily
from manigraph_shelf.sim.options import ShelfOptions
from manigraph_shelf.sim.scene import shelf_scene
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.tasks import get_task


def world(objects: int = 4, seed: int = 0) -> ShelfWorld:
    task = get_task("shelf", ShelfOptions(objects=objects))
    return ShelfWorld(task.layout(np.random.default_rng(seed)))


def put(w: ShelfWorld, block: str, slot_id: str) -> None:
    slot = next(s for s in w.slots if s.id == slot_id)
    w.pick(block)
    w.place(block, np.array(slot.position))


def test_slots_fill_levels_of_three_columns_back_and_front() -> None:
    slots = slots_for(8)
    assert [s.row for s in slots] == [BACK, FRONT] * 4
    assert [s.level for s in slots] == [0] * 6 + [1] * 2  # three columns, then one above
    assert all(s.position[0] > f.position[0] for s, f in zip(slots[::2], slots[1::2], strict=True))
    assert (levels_for(4), levels_for(12), levels_for(14), levels_for(18)) == (2, 2, 3, 3)
    for bad in (0, 3, 20):
        with pytest.raises(TaskError, match="objects"):
            get_task("shelf", ShelfOptions(objects=bad))


def test_a_filled_front_slot_blocks_the_back_slot_and_the_block_stays_put() -> None:
    w = world()
    put(w, "block_0", "slot_0_0_front")
    start = w.positions["block_1"].copy()
    w.pick("block_1")
    with pytest.raises(SkillError) as refused:
        w.place("block_1", np.array(w.slots[0].position))  # slot_0_0_back
    assert refused.value.reason == "slot_blocked"
    assert w.held is None and np.allclose(w.positions["block_1"], start)
    assert "slot_0_0_back" not in w.filled()
    put(w, "block_1", "slot_0_1_back")  # another column's back slot is still free
    put(w, "block_0", "slot_0_0_back")  # lifted out of the front slot, it blocks no more
    assert w.filled() == {"slot_0_0_back", "slot_0_1_back"}


def test_success_is_every_slot_filled() -> None:
    family = ShelfFamily()
    layout = get_task("shelf", ShelfOptions(objects=4)).layout(np.random.default_rng(0))
    w = ShelfWorld(layout)
    for block, slot in zip(["block_0", "block_1", "block_2"], w.slots, strict=False):
        put(w, block, slot.id)
    partial = family.evaluate(layout, w)
    assert (partial.filled, partial.total, partial.success) == (3, 4, False)
    put(w, "block_3", w.slots[3].id)
    assert family.evaluate(layout, w).success
    scene = shelf_scene(w, layout, "e", 0.0, 0, ended=False)
    assert all(goal.filled for goal in scene.goals) and all(o.filled for o in scene.objects)
    assert {goal.attributes[ROW_ATTRIBUTE] for goal in scene.goals} == {BACK, FRONT}


class FrontFirst(Policy):
    """Fills front slots first: every back slot is then out of reach."""

    name = "front-first"

    def decide(self, scene: Scene) -> Decision | None:
        loose = [o for o in scene.objects if not o.filled]
        free = sorted(
            (g for g in scene.goals if not g.filled),
            key=lambda g: g.attributes[ROW_ATTRIBUTE] != FRONT,
        )
        return Decision(loose[0].id, free[0].id) if loose and free else None


def test_front_slots_first_never_finish_the_shelf() -> None:
    request = EpisodeRequest(episode_id="e", task="shelf", objects=4, seed=53900)
    record = run_episode(FrontFirst(), request)
    assert not record.success
    assert record.end.goals_filled == 2  # the two front slots; their back slots refused
    assert any(step.reason == "slot_blocked" for step in record.steps)


def test_the_cupboard_shows_as_fixtures_the_planner_leaves_out() -> None:
    request = EpisodeRequest(episode_id="e", task="shelf", objects=14, seed=53930)
    layout = get_task("shelf", ShelfOptions(objects=14)).layout(np.random.default_rng(53930))
    scene = shelf_scene(ShelfWorld(layout), layout, "e", 0.0, 0, ended=False)
    boards = sorted((f for f in scene.fixtures if f.kind == BOARD), key=lambda f: f.position.z)
    assert len(boards) == layout.geometry.levels == 3
    assert sum(f.kind == WALL for f in scene.fixtures) == 3  # two sides and the back
    extents = [(b.position, b.size) for b in boards]
    for slot in layout.slots:  # under its level's board, over the one below, inside their spans
        over, over_size = extents[slot.level]
        x, y, z = slot.position
        assert over_size is not None and z < over.z - over_size.z / 2
        assert abs(x - over.x) < over_size.x / 2 and abs(y - over.y) < over_size.y / 2
        if slot.level > 0:
            under, under_size = extents[slot.level - 1]
            assert under_size is not None and z > under.z + under_size.z / 2
    bare = msgspec.structs.replace(scene, fixtures=[])
    spec = FeatureSpec.for_task(TaskFeatures.learn([scene]))
    assert spec.task is not None and spec.task.goal_attributes == (ROW_ATTRIBUTE,)
    graph, without = scene_to_graph(scene, spec), scene_to_graph(bare, spec)
    assert torch.equal(graph.x, without.x) and torch.equal(graph.edge_index, without.edge_index)
    expert = FAMILIES["shelf"].expert(request)
    assert expert.decide(scene) == expert.decide(bare)
