"""Training on a task's columns: generic augmentation, the spec carried to the network."""

from __future__ import annotations

import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_planner.gnn.features import FEATURE_SPEC, FeatureSpec, scene_to_graph
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_training.dataset import Demonstrations, Sample
from manigraph_training.recipes import augmentation_for
from manigraph_training.trainer import TrainConfig, train


def colour_scene() -> Scene:
    objects = [
        SceneObject(
            id=f"b{i}",
            category="block",
            position=Vector3(x=0.4 + 0.1 * i, y=-0.2, z=0.02),
            size=Vector3(x=0.04, y=0.04, z=0.04),
            attributes={"colour": colour},
        )
        for i, colour in enumerate(["red", "blue"])
    ]
    goals = [
        SceneGoal(
            id=f"{colour}_slot",
            category="block",
            position=Vector3(x=0.4 + 0.1 * i, y=0.2, z=0.02),
            accepts={"colour": colour},
        )
        for i, colour in enumerate(["red", "blue"])
    ]
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


def demos() -> Demonstrations:
    scene = colour_scene()
    spec = FeatureSpec.for_task(TaskFeatures.learn([scene]))
    graph = scene_to_graph(scene, spec)
    sample = Sample(graph.x, graph.is_object, 0, 2)  # b0 (red) to red_slot
    return Demonstrations([sample], "hash", 1, 0, spec)


def test_task_augmentation_moves_positions_only_and_keeps_labels_and_nodes() -> None:
    augmentation = augmentation_for("sage").for_task()
    assert augmentation.generic and augmentation == Augmentation().for_task()
    sample = demos().samples[0]
    copies = augmentation.apply([sample], torch.Generator().manual_seed(0))
    assert len(copies) == 1 + augmentation.copies
    for copy in copies[1:]:
        assert copy.x.shape == sample.x.shape
        assert (copy.object_index, copy.goal_index) == (0, 2)
        assert torch.equal(
            copy.x[:, [0, *range(4, sample.x.shape[1])]],
            sample.x[:, [0, *range(4, sample.x.shape[1])]],
        )
        assert not torch.equal(copy.x[:, 1:4], sample.x[:, 1:4])


def test_training_on_a_tasks_demonstrations_builds_a_network_of_its_columns() -> None:
    data = demos()
    config = TrainConfig(architecture="sage", epochs=2, augmentation=augmentation_for("sage", 1))
    assert config.for_task(FEATURE_SPEC) is config
    task_config = config.for_task(data.feature_spec)
    assert task_config.features == data.feature_spec
    assert task_config.augmentation is not None and task_config.augmentation.generic
    assert "features" not in task_config.to_dict()
    net, metrics = train(data, config)
    assert net.config.feature_spec == data.feature_spec
    assert net.config.input_size == data.feature_spec.num_features
    assert metrics["demonstration_samples"] == 1
