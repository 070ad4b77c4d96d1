"""Towers grown past the demonstrated height (``--grow`` on a tower; issue #49)."""

from __future__ import annotations

import pytest
import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_blocks.training.task_growth import grow_task_graph
from manigraph_planner.gnn.features import FeatureSpec, scene_to_graph
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

COLOURS = ("red", "green", "blue")


def rgb_tower_two_done() -> Scene:
    """Levels r, g, b; red and green placed, the blue block loose (the expert's next)."""
    objects = [
        SceneObject(
            id=f"b{k}",
            category="block",
            position=Vector3(x=0.66 if k < 2 else 0.3, y=0.0, z=0.02 + 0.04 * k if k < 2 else 0.02),
            size=Vector3(x=0.04, y=0.04, z=0.04),
            attributes={"colour": COLOURS[k]},
            filled=k < 2,
        )
        for k in range(3)
    ]
    goals = [
        SceneGoal(
            id=f"level_{k}",
            category="block",
            position=Vector3(x=0.66, y=0.0, z=0.02 + 0.04 * k),
            accepts={"colour": COLOURS[k]},
            filled=k < 2,
        )
        for k in range(3)
    ]
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


def grown(
    seed: int, written: bool
) -> tuple[torch.Tensor, torch.Tensor, int, int, int, FeatureSpec]:
    scene = rgb_tower_two_done()
    spec = FeatureSpec.for_task(TaskFeatures.learn([scene]))
    growth = Augmentation().for_task(spec)
    assert growth.ready_column == spec.names.index("goal:ready")
    x = scene_to_graph(scene, spec).x
    # the expert's decision: the blue block (object 2) to level_2 (node 3 + 2); without
    # written accepts the goals' any columns are read as open (a rule nobody wrote)
    out, objects, goal_index, object_index = grow_task_graph(
        x,
        3,
        2,
        5,
        0,
        2,
        torch.Generator().manual_seed(seed),
        growth.ready_column,
        growth.any_columns if written else (),
    )
    return x, out, objects, goal_index, object_index, spec


@pytest.mark.parametrize("written", [True, False])
def test_finished_levels_grow_the_tower_in_place_or_as_free_levels_on_top(written: bool) -> None:
    kinds = set()
    for seed in range(12):
        x, out, objects, goal_index, object_index, spec = grown(seed, written)
        ready = spec.names.index("goal:ready")
        red = spec.names.index("colour=red")
        assert objects == 5 and out.shape == (x.shape[0] + 4, x.shape[1])
        # the label is the same blue block and the same blue level, still the only ready one
        assert torch.equal(out[object_index, 5:], x[2, 5:])
        assert torch.equal(out[goal_index, 5:], x[5, 5:])
        goals = out[objects:]
        assert goals[:, ready].tolist().count(1.0) == 1 and out[goal_index, ready] == 1
        # every goal still stands in the tower's column, one level apart
        assert torch.allclose(goals[:, 1:3], x[3, 1:3].expand(len(goals), -1))
        heights = sorted(round(float(z), 4) for z in goals[:, 3])
        assert heights == [round(0.02 + 0.04 * k, 4) for k in range(5)]
        # the free levels are exactly the labelled one and those above it
        free = goals[goals[:, 4] == 0]
        assert float(free[:, 3].min()) == float(out[goal_index, 3])
        for copy in range(2):  # each new level with its object
            goal, obj = goals[3 + copy], out[3 + copy]
            if goal[4] == 1:  # inserted, filled, its object resting in it
                kinds.add("in place")
                assert torch.allclose(obj[1:4], goal[1:4])
            else:  # on top, free, its object loose on the table
                kinds.add("on top")
                assert obj[4] == 0 and float(obj[3]) == float(x[3, 3])
                assert float(goal[3]) > float(out[goal_index, 3])
                # written: a finished level (red, green); else the decided one (blue) again
                same_as_label = torch.equal(obj[5:], x[2, 5:])
                assert same_as_label is not written
            assert torch.equal(goal[red], obj[red])  # the level accepts its own object
    assert kinds == {"in place", "on top"}
