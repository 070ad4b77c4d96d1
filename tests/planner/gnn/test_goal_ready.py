"""Which goal can be filled now (``goal:ready``), and sizes admitted by the judge's tolerance."""

from __future__ import annotations

import pytest
import torch

from manigraph_planner.gnn.features import FeatureSpec, scene_to_graph
from manigraph_planner.gnn.goal_support import ready_goals, stands_on_goals, supports_of
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.acceptance import SIZE_TOLERANCE
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3


def block(
    name: str, x: float, y: float, z: float, colour: str, filled: bool = False
) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=y, z=z),
        size=Vector3(x=0.04, y=0.04, z=0.04),
        attributes={"colour": colour},
        filled=filled,
    )


def level(k: int, colour: str, filled: bool = False) -> SceneGoal:
    return SceneGoal(
        id=f"level_{k}",
        category="block",
        position=Vector3(x=0.66, y=0.0, z=0.02 + 0.04 * k),
        accepts={"colour": colour},
        filled=filled,
    )


def tower(done: int, levels: int = 6) -> Scene:
    """An r, g, b, r, g, b tower with its ``done`` lowest levels filled."""
    colours = ["red", "green", "blue"]
    objects = [
        block(f"placed_{k}", 0.66, 0.0, 0.02 + 0.04 * k, colours[k % 3], True) for k in range(done)
    ]
    objects += [
        block(f"loose_{k}", 0.3, -0.3 + 0.11 * k, 0.02, colours[k % 3]) for k in range(done, levels)
    ]
    goals = [level(k, colours[k % 3], k < done) for k in range(levels)]
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


def test_only_the_lowest_free_level_of_a_tower_is_ready() -> None:
    assert supports_of(tower(0))["level_3"] == ["level_2"]
    assert supports_of(tower(0))["level_0"] == []
    for done in range(6):
        assert ready_goals(tower(done)) == {f"level_{done}"}
    assert ready_goals(tower(6)) == frozenset()


def test_goals_side_by_side_are_all_ready_and_a_blocked_goal_is_not() -> None:
    goals = [
        SceneGoal(id=f"bin_{k}", category="block", position=Vector3(x=0.63, y=0.1 * k, z=0.02))
        for k in range(3)
    ]
    lying = block("lying", 0.63, 0.2, 0.06, "red")  # on top of bin_2's spot
    scene = Scene(episode_id="t", stamp=1.0, sequence=0, objects=[lying], goals=goals)
    assert not stands_on_goals(scene)
    assert ready_goals(scene) == {"bin_0", "bin_1"}


def test_towers_bring_the_ready_column_last_and_it_marks_the_next_level() -> None:
    spec = FeatureSpec.for_task(TaskFeatures.learn([tower(0, 3)]))
    assert spec.task is not None and spec.task.goal_support
    assert spec.names[-1] == "goal:ready"
    graph = scene_to_graph(tower(4), spec)
    ready = graph.x[:, -1]
    assert ready[: graph.num_objects].tolist() == [0.0] * 6
    assert ready[graph.num_objects :].tolist() == [0, 0, 0, 0, 1, 0]
    # the stamp records it, and a stamp without it (every older checkpoint) reads as before
    values = spec.task.to_dict()
    assert values["goal_support"] is True
    assert TaskFeatures.from_dict(values) == spec.task
    del values["goal_support"]
    older = FeatureSpec.for_task(TaskFeatures.from_dict(values))
    assert "goal:ready" not in older.names
    assert scene_to_graph(tower(4), older).x.shape[1] == spec.num_features - 1
    with pytest.raises(ValueError, match="goal_support"):
        TaskFeatures.from_dict({**spec.task.to_dict(), "goal_support": "yes"})


def test_bins_learn_no_ready_column() -> None:
    scene = Scene(
        episode_id="t",
        stamp=1.0,
        sequence=0,
        objects=[block("a", 0.3, 0.0, 0.02, "red")],
        goals=[SceneGoal(id="bin", category="block", position=Vector3(x=0.6, y=0.0, z=0.02))],
    )
    task = TaskFeatures.learn([scene])
    assert task is not None and not task.goal_support and "goal:ready" not in task.names


@pytest.mark.parametrize(("gap", "admitted"), [(0.0, True), (0.001, True), (0.0015, False)])
def test_the_filter_admits_sizes_within_the_judges_tolerance(gap: float, admitted: bool) -> None:
    assert SIZE_TOLERANCE == 0.001
    task = TaskFeatures()
    width = 0.06 + gap
    objects = torch.zeros(1, 5 + len(task.names))
    goals = torch.zeros(1, 5 + len(task.names))
    objects[0, 5:8] = torch.tensor([width, width, 0.04]) * task.size_scale
    goals[0, 5:8] = torch.tensor([0.06, 0.06, 0.04]) * task.size_scale
    assert bool(task.admits(objects, goals)[0, 0]) is admitted
