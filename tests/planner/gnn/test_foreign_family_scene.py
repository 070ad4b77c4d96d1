"""A scene of another family given to the paper's graph state is refused naming the family and
the heads its scenes need, as the planner's family registry says (the generic graph code
names no family)."""

from __future__ import annotations

import pytest

from manigraph_planner.gnn.features import scene_to_graph
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend


def first_scene(task: str, **request: int) -> Scene:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, **request), 0.0)
    return backend.scene(1.0)


def test_a_dish_scene_is_refused_naming_its_familys_heads() -> None:
    with pytest.raises(PolicyError) as refused:
        scene_to_graph(first_scene("dishwasher", objects=4))
    message = str(refused.value)
    assert "this policy knows blocks and covers" in message
    assert message.endswith("(a dishwasher scene needs a checkpoint with dishwasher heads)")


def test_a_block_scene_makes_a_graph() -> None:
    scene = first_scene("box-pack", blocks=3)
    graph = scene_to_graph(scene)
    assert graph.object_ids == [o.id for o in scene.objects if o.visible]  # blocks and a cover
