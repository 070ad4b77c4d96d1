"""Task-file scenes grown past the demonstrated size (``--grow``; issue #49)."""

from __future__ import annotations

from dataclasses import replace

import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_blocks.training.task_growth import grow_task_graph
from manigraph_planner.gnn.features import FeatureSpec, scene_to_graph
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_training.dataset import Sample


def bins_scene() -> Scene:
    """Two loose blocks (red, blue), a red block already in the left bin, left and right
    bins of two goals each; no goal says what it accepts (a rule nobody wrote)."""

    def block(name: str, x: float, y: float, colour: str) -> SceneObject:
        return SceneObject(
            id=name,
            category="block",
            position=Vector3(x=x, y=y, z=0.02),
            size=Vector3(x=0.04, y=0.04, z=0.04),
            attributes={"colour": colour},
            filled=name == "done",
        )

    def goal(name: str, y: float, filled: bool = False) -> SceneGoal:
        return SceneGoal(
            id=name, category="block", position=Vector3(x=0.63, y=y, z=0.02), filled=filled
        )

    return Scene(
        episode_id="t",
        stamp=1.0,
        sequence=0,
        objects=[
            block("red", 0.3, 0.0, "red"),
            block("blue", 0.4, 0.1, "blue"),
            block("done", 0.63, -0.19, "red"),
        ],
        goals=[goal("l0", -0.19, True), goal("l1", -0.13), goal("r0", 0.13), goal("r1", 0.19)],
    )


def graph_x() -> tuple[torch.Tensor, FeatureSpec]:
    scene = bins_scene()
    spec = FeatureSpec.for_task(TaskFeatures.learn([scene]))
    return scene_to_graph(scene, spec).x, spec


def test_the_decided_pair_and_finished_pairs_are_copied_and_the_label_kept() -> None:
    x, _ = graph_x()
    generator = torch.Generator().manual_seed(0)
    # the expert's decision: blue (object 1) to r0 (node 3 + 2)
    grown, objects, goal_index, object_index = grow_task_graph(x, 3, 1, 5, 3, 2, generator)
    assert objects == 3 + 3 + 1  # three pair copies, the one finished pair once
    assert grown.shape == (x.shape[0] + 8, x.shape[1])
    assert torch.equal(grown[object_index], x[1]) and torch.equal(grown[goal_index], x[5])
    assert bool((grown[:objects, 0] == 1).all()) and bool((grown[objects:, 0] == 2).all())
    pair_objects, finished_object = grown[3:6], grown[6]
    pair_goals, finished_goal = grown[objects + 4 : objects + 7], grown[objects + 7]
    # copies keep every task column (the blue colour), loose and free
    assert torch.equal(pair_objects[:, 5:], x[1, 5:].expand(3, -1))
    assert bool((pair_objects[:, 4] == 0).all()) and bool((pair_goals[:, 4] == 0).all())
    # each copied goal stays nearer its original than any other goal: in the right bin
    others = torch.cat([x[3:5, 1:3], x[6:, 1:3]])
    for copy in pair_goals[:, 1:3]:
        own = float((copy - x[5, 1:3]).norm())
        assert own < float((others - copy).norm(dim=1).min())
    # the finished pair moves together and stays filled
    assert finished_object[4] == 1 and finished_goal[4] == 1
    shift = finished_goal[1:3] - x[3, 1:3]
    assert torch.allclose(finished_object[1:3] - x[2, 1:3], shift)


def test_growth_is_off_unless_asked_and_grows_augmented_task_copies() -> None:
    x, _ = graph_x()
    is_object = torch.tensor([True] * 3 + [False] * 4)
    sample = Sample(x, is_object, 1, 5)
    plain = Augmentation().for_task()
    assert (plain.grow_pairs, plain.grow_finished) == (0, 0)
    assert plain.randomize(sample, torch.Generator().manual_seed(0)).x.shape == x.shape
    grown = replace(plain, grow_pairs=4, grow_finished=4)
    sizes = set()
    for copy in grown.apply([sample], torch.Generator().manual_seed(1))[1:]:
        objects = int(copy.is_object.sum())
        assert bool(copy.is_object[:objects].all()) and not bool(copy.is_object[objects:].any())
        assert copy.x[copy.object_index, 5:].tolist() == x[1, 5:].tolist()
        assert copy.x[copy.goal_index, 0] == 2 and not copy.is_object[copy.goal_index]
        sizes.add(copy.x.shape[0])
    assert len(sizes) > 3 and max(sizes) > x.shape[0]
