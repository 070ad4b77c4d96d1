"""Box tasks in physics: static boxes, covers as real bodies lifted off by their handle, blocks
in and out of boxes, and the geometric world's partial-observability rule on simulated poses."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_blocks.sim.options import BlockOptions
from manigraph_blocks.sim.physics_boxes import PHYSICS_BOXES
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest, SkillState
from manigraph_sim.backends import create_backend
from manigraph_sim.tasks import get_task

Loop = Any  # tests/physics/conftest.py: InProcessLoop


def _position(scene: Any, object_id: str) -> np.ndarray:
    return np.array(scene.object(object_id).position.as_tuple())


def test_a_cover_is_lifted_off_by_its_handle_and_put_back(loop: Loop) -> None:
    scene = loop.reset(task="box-pack", blocks=1, seed=0)
    assert scene.object("cover_0").filled and scene.goal("lid_goal_0").filled
    assert loop.move("cover_0", "storage_0").state is SkillState.SUCCEEDED
    scene = loop.scene()
    assert scene.goal("storage_0").filled and not scene.goal("lid_goal_0").filled
    storage = np.array(scene.goal("storage_0").position.as_tuple())
    assert np.linalg.norm(_position(scene, "cover_0") - storage) < 0.01
    assert loop.move("cover_0", "lid_goal_0").state is SkillState.SUCCEEDED
    scene = loop.scene()
    assert scene.goal("lid_goal_0").filled and not scene.goal("storage_0").filled
    # Resting on the rim, level: the Scene reports the plate's centre.
    assert np.isclose(scene.object("cover_0").position.z, PHYSICS_BOXES.lid_height, atol=2e-3)


def test_a_block_is_taken_out_of_a_box(loop: Loop) -> None:
    loop.reset(task="box-unpack", blocks=3, seed=1)
    assert loop.move("cover_0", "storage_0").state is SkillState.SUCCEEDED
    # The centre block first (the expert's choice): neighbours on -x, -y; fingers along y.
    assert loop.move("block_0", "goal_0").state is SkillState.SUCCEEDED
    scene = loop.scene()
    assert scene.goal("goal_0").filled and scene.object("block_0").filled
    assert all(not scene.object(f"block_{i}").filled for i in (1, 2))  # still in the box


def test_closed_boxes_hide_their_contents_until_opened_as_in_the_geometric_world(
    loop: Loop,
) -> None:
    request = EpisodeRequest(episode_id="g", task="box-rearrangement", blocks=2, seed=3)
    geometric = create_backend("geometric")
    geometric.reset(request, 1.0)
    expected = geometric.scene(1.0)
    scene = loop.reset(task="box-rearrangement", blocks=2, seed=3)
    visible = {o.id: o.visible for o in scene.objects} | {g.id: g.visible for g in scene.goals}
    assert visible == {o.id: o.visible for o in expected.objects} | {
        g.id: g.visible for g in expected.goals
    }
    assert not scene.object("block_0").visible and not scene.goal("goal_0").visible
    assert scene.object("cover_1").visible and scene.goal("storage_0").visible
    assert loop.move("cover_0", "storage_0").state is SkillState.SUCCEEDED
    scene = loop.scene()
    assert scene.object("block_0").visible and scene.object("block_1").visible
    assert not scene.goal("goal_0").visible  # the other box is still closed
    assert loop.move("cover_0", "lid_goal_0").state is SkillState.SUCCEEDED
    assert loop.scene().object("block_0").visible  # seen once, known from then on


@pytest.mark.slow
def test_the_expert_packs_three_blocks_into_a_box(loop: Loop) -> None:
    expert = ExpertPolicy()
    scene = loop.reset(task="box-pack", blocks=3, seed=0)
    while not scene.episode_ended:
        decision = expert.decide(scene)
        assert decision is not None
        assert loop.move(decision.object_id, decision.goal_id).state is SkillState.SUCCEEDED
        scene = loop.scene()
    end = loop.backend.end_event(time.time())
    assert end is not None and end.success and end.steps == 5  # open, 3 blocks, close


def test_the_physical_box_geometry_leaves_finger_room_and_fits_the_sites() -> None:
    g = PHYSICS_BOXES
    params = BlockOptions(blocks=4, boxes=g)
    for seed in range(20):
        layout = get_task("box-rearrangement", params).layout(np.random.default_rng(seed))
        sites = [c.centre for c in layout.containers]
        sites += [goal.position[:2] for goal in layout.goals if goal.id.startswith("storage")]
        for i, a in enumerate(sites):
            for b in sites[i + 1 :]:
                assert np.max(np.abs(a - b)) >= g.cover_size[0]  # footprints never overlap
        for body in layout.bodies:
            assert np.linalg.norm(body.position[:2]) < 0.78  # top-down reach of the Panda
    with pytest.raises(TaskError, match="blocks"):
        get_task("box-pack", BlockOptions(blocks=5, boxes=g))
