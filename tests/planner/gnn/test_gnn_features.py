from __future__ import annotations

import pytest
import torch

from manigraph_planner.gnn.features import (
    FEATURE_SPEC,
    FeatureSpec,
    fully_connected_edge_index,
    graph_from_arrays,
    scene_to_graph,
)
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

SIZE = Vector3(x=0.04, y=0.04, z=0.04)


def hand_made_scene() -> Scene:
    objects = [
        SceneObject(id="lid", category="cover", position=Vector3(x=0.1, y=0.2, z=0.3), size=SIZE),
        SceneObject(
            id="b1",
            category="block",
            position=Vector3(x=0.4, y=-0.1, z=0.02),
            size=SIZE,
            filled=True,
        ),
        SceneObject(
            id="in-box",
            category="block",
            position=Vector3(x=0.7, y=0.0, z=0.02),
            size=SIZE,
            visible=False,
        ),
        SceneObject(id="b2", category="block", position=Vector3(x=-0.3, y=0.5, z=0.06), size=SIZE),
    ]
    goals = [
        SceneGoal(id="g1", category="block", position=Vector3(x=0.5, y=0.0, z=0.02), filled=True),
        SceneGoal(
            id="hidden-goal",
            category="block",
            position=Vector3(x=0.7, y=0.0, z=0.02),
            visible=False,
        ),
        SceneGoal(id="gc", category="cover", position=Vector3(x=0.6, y=0.1, z=0.1)),
    ]
    return Scene(episode_id="e", stamp=1.0, sequence=0, objects=objects, goals=goals)


def test_node_features_follow_the_paper() -> None:
    graph = scene_to_graph(hand_made_scene())
    expected = torch.tensor(
        [
            [0.0, 0.1, 0.2, 0.3, 0.0],  # cover
            [1.0, 0.4, -0.1, 0.02, 1.0],  # block resting in a goal
            [1.0, -0.3, 0.5, 0.06, 0.0],  # block
            [2.0, 0.5, 0.0, 0.02, 1.0],  # filled goal for a block
            [3.0, 0.6, 0.1, 0.1, 0.0],  # free goal for a cover
        ]
    )
    assert graph.x.dtype == torch.float32
    assert torch.equal(graph.x, expected)
    assert graph.object_ids == ["lid", "b1", "b2"]
    assert graph.goal_ids == ["g1", "gc"]
    assert graph.is_object.tolist() == [True, True, True, False, False]


def test_invisible_objects_and_goals_are_not_nodes() -> None:
    graph = scene_to_graph(hand_made_scene())
    assert graph.num_nodes == 5
    assert "in-box" not in graph.object_ids and "hidden-goal" not in graph.goal_ids
    assert graph.edge_index.max() < graph.num_nodes


@pytest.mark.parametrize("num_nodes", [0, 1, 2, 5, 80])
def test_graph_is_fully_connected_without_self_loops(num_nodes: int) -> None:
    edge_index = fully_connected_edge_index(num_nodes)
    assert edge_index.dtype == torch.long
    assert edge_index.shape == (2, num_nodes * (num_nodes - 1))
    source, target = edge_index.tolist()
    assert all(s != t for s, t in zip(source, target, strict=True))
    pairs = set(zip(source, target, strict=True))
    assert pairs == {(s, t) for s in range(num_nodes) for t in range(num_nodes) if s != t}


def test_scene_graph_edges_cover_every_ordered_pair() -> None:
    graph = scene_to_graph(hand_made_scene())
    assert graph.edge_index.shape == (2, 5 * 4)
    assert not bool((graph.edge_index[0] == graph.edge_index[1]).any())


def test_edge_index_is_cached_per_node_count() -> None:
    assert fully_connected_edge_index(7) is fully_connected_edge_index(7)
    assert fully_connected_edge_index(7) is not fully_connected_edge_index(8)


def test_graph_from_arrays_matches_scene_to_graph() -> None:
    from_scene = scene_to_graph(hand_made_scene())
    from_arrays = graph_from_arrays(
        from_scene.x[:, 0].long(),
        from_scene.x[:, 1:4],
        from_scene.x[:, 4],
        object_ids=["lid", "b1", "b2"],
        goal_ids=["g1", "gc"],
    )
    assert torch.equal(from_arrays.x, from_scene.x)
    assert torch.equal(from_arrays.edge_index, from_scene.edge_index)
    assert torch.equal(from_arrays.is_object, from_scene.is_object)
    assert from_arrays.goal_ids == ["g1", "gc"]


def test_graph_from_arrays_names_nodes_by_default() -> None:
    graph = graph_from_arrays([1, 1, 2], [[0, 0, 0]] * 3, [0, 0, 0])
    assert graph.object_ids == ["object-0", "object-1"] and graph.goal_ids == ["goal-0"]


@pytest.mark.parametrize(
    ("category", "position", "filled", "field"),
    [
        ([1, 7], [[0, 0, 0]] * 2, [0, 0], "category"),
        ([2, 1], [[0, 0, 0]] * 2, [0, 0], "category"),  # goal before object
        ([1, 2], [[0, 0]] * 2, [0, 0], "position"),
        ([1, 2], [[0, 0, float("nan")]] * 2, [0, 0], "position"),
        ([1, 2], [[0, 0, 0]] * 2, [0, 2], "filled"),
        ([1, 2], [[0, 0, 0]] * 2, [0], "filled"),
    ],
)
def test_graph_from_arrays_rejects_bad_input_naming_the_argument(
    category: list[int], position: list[list[float]], filled: list[int], field: str
) -> None:
    with pytest.raises(ValueError, match=rf"^{field}:"):
        graph_from_arrays(category, position, filled)


def test_feature_spec_is_the_papers() -> None:
    assert FEATURE_SPEC.names == ("category", "x", "y", "z", "filled")
    assert dict(FEATURE_SPEC.category_codes) == {
        "cover": 0,
        "block": 1,
        "block-goal": 2,
        "cover-goal": 3,
    }
    assert FEATURE_SPEC.to_dict()["names"] == ["category", "x", "y", "z", "filled"]


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"names": ("x", "x")}, "names"),
        ({"category_codes": (("cover", 0), ("block", 0))}, "category_codes"),
        ({"version": ""}, "version"),
    ],
)
def test_feature_spec_rejects_bad_values(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}:"):
        FeatureSpec(**kwargs)  # type: ignore[arg-type]
