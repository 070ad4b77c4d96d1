"""A task's feature columns: learned from scenes, stamped in checkpoints, checked on load."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import torch

from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.gnn.features import FEATURE_SPEC, FeatureSpec, scene_to_graph
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

REPO = Path(__file__).resolve().parents[3]


def obj(name: str, x: float, size: float = 0.04, **attributes: str | float) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=-0.2, z=size / 2),
        size=Vector3(x=size, y=size, z=size),
        attributes=attributes,
    )


def goal(name: str, x: float, **accepts: Any) -> SceneGoal:
    return SceneGoal(
        id=name, category="block", position=Vector3(x=x, y=0.2, z=0.02), accepts=accepts
    )


def scene(objects: list[SceneObject], goals: list[SceneGoal]) -> Scene:
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


COLOURS = scene(
    [obj("block_0", 0.4, colour="red", weight=2.0), obj("block_1", 0.5, colour="blue", weight=4.0)],
    [goal("red_slot", 0.4, colour="red"), goal("any_slot", 0.5), goal("part", 0.6, id="block_1")],
)


def column(spec: FeatureSpec, name: str) -> int:
    return spec.names.index(name)


def test_scenes_without_attributes_or_accepts_keep_the_papers_five_columns() -> None:
    plain = scene([obj("b", 0.4)], [goal("g", 0.4)])
    assert TaskFeatures.learn([plain]) is None
    assert FeatureSpec.for_task(None) is FEATURE_SPEC
    assert scene_to_graph(plain).x.shape == (2, 5)


def test_blocks_of_several_sizes_bring_the_size_columns_without_any_attribute() -> None:
    sizes = scene([obj("small", 0.4, size=0.03), obj("big", 0.5, size=0.07)], [goal("g", 0.4)])
    task = TaskFeatures.learn([sizes])
    assert task is not None and task.attributes == ()
    spec = FeatureSpec.for_task(task)
    assert spec.names[5:] == ("size_x", "size_y", "size_z", "size:any")
    x = scene_to_graph(sizes, spec).x
    assert x[1, column(spec, "size_z")] == pytest.approx(0.7)  # what "big" is, in decimetres


def test_vocabulary_one_hot_numeric_scale_and_ids_are_learned() -> None:
    task = TaskFeatures.learn([COLOURS])
    assert task is not None
    spec = FeatureSpec.for_task(task)
    assert spec.names[:5] == FEATURE_SPEC.names
    assert spec.names[5:] == (
        "size_x",
        "size_y",
        "size_z",
        "size:any",
        "colour=blue",
        "colour=red",
        "colour:any",
        "weight",
        "weight:any",
        "id=block_1",
        "id:any",
    )
    x = scene_to_graph(COLOURS, spec).x
    assert x.shape == (5, spec.num_features)
    red, blue = x[0], x[1]
    assert red[column(spec, "colour=red")] == 1 and red[column(spec, "colour=blue")] == 0
    assert blue[column(spec, "colour=blue")] == 1 and blue[column(spec, "colour:any")] == 0
    assert red[column(spec, "weight")] == 0.0 and blue[column(spec, "weight")] == 1.0
    assert red[column(spec, "size_z")] == pytest.approx(0.4)  # decimetres
    assert blue[column(spec, "id=block_1")] == 1 and red[column(spec, "id=block_1")] == 0


def test_a_goals_accepts_fills_the_same_columns_and_any_marks_what_it_leaves_open() -> None:
    spec = FeatureSpec.for_task(TaskFeatures.learn([COLOURS]))
    x = scene_to_graph(COLOURS, spec).x
    red_slot, any_slot, part = x[2], x[3], x[4]
    assert red_slot[column(spec, "colour=red")] == 1
    assert red_slot[column(spec, "colour:any")] == 0
    for name in ("size:any", "weight:any", "id:any"):
        assert red_slot[column(spec, name)] == 1
    for name in ("colour:any", "size:any", "weight:any", "id:any"):
        assert any_slot[column(spec, name)] == 1
    assert float(any_slot[column(spec, "colour=red")]) == 0.0
    assert part[column(spec, "id=block_1")] == 1 and part[column(spec, "id:any")] == 0


def test_a_goal_accepting_a_size_shows_it_in_the_objects_size_columns() -> None:
    sized = scene(
        [obj("small", 0.4, size=0.03)],
        [
            SceneGoal(
                id="g",
                category="block",
                position=Vector3(x=0.4, y=0.2, z=0.015),
                accepts={"size": [0.03, 0.03, 0.03]},
            )
        ],
    )
    spec = FeatureSpec.for_task(TaskFeatures.learn([sized]))
    x = scene_to_graph(sized, spec).x
    sizes = [column(spec, n) for n in ("size_x", "size_y", "size_z")]
    assert torch.allclose(x[0, sizes], x[1, sizes])
    assert x[1, column(spec, "size:any")] == 0


def test_a_value_outside_the_vocabulary_reads_as_other_with_one_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    spec = FeatureSpec.for_task(TaskFeatures.learn([COLOURS]))
    values = [column(spec, "colour=blue"), column(spec, "colour=red")]
    stone = scene(
        [obj("block_3", 0.4, colour="stone_x"), obj("block_4", 0.5, colour="stone_x")],
        [goal("g", 0.4)],
    )
    with caplog.at_level("WARNING", logger="manigraph_planner.gnn.task_features"):
        x = scene_to_graph(stone, spec).x
        scene_to_graph(stone, spec)
    assert x[0, values].tolist() == [0.0, 0.0] and x[1, values].tolist() == [0.0, 0.0]
    warned = [r.getMessage() for r in caplog.records]
    assert warned == [
        "scene: block_3 colour 'stone_x' is not in this policy's vocabulary (blue, red): "
        "read as other"
    ]
    asks = scene([obj("b", 0.4, colour="red")], [goal("slot_9", 0.4, colour="green_x")])
    x = scene_to_graph(asks, spec).x
    assert x[1, values].tolist() == [0.0, 0.0] and x[1, column(spec, "colour:any")] == 0
    task = spec.task
    assert task is not None and not bool(task.admits(x[:1], x[1:]).any())  # admits nothing
    unknown = scene([obj("b", 0.4)], [goal("slot_2", 0.4, label="bolt")])
    with pytest.raises(PolicyError, match="goal slot_2 accepts by 'label', which this policy"):
        scene_to_graph(unknown, spec)
    number = scene([obj("b", 0.4, colour=3.0)], [goal("g", 0.4)])
    with pytest.raises(PolicyError, match=r"b colour 3\.0 is a number; this policy knows words"):
        scene_to_graph(number, spec)


def test_a_goals_own_attributes_become_columns_like_an_objects(tmp_path: Path) -> None:
    bins = scene(
        [obj("block_0", 0.4, colour="red"), obj("block_1", 0.5, colour="blue")],
        [
            SceneGoal(
                id="bin_0",
                category="block",
                position=Vector3(x=0.4, y=0.2, z=0.02),
                attributes={"colour": "blue"},
            ),
            goal("bin_1", 0.5),
        ],
    )
    task = TaskFeatures.learn([bins])
    assert task is not None and task.goal_attributes == ("colour",)
    spec = FeatureSpec.for_task(task)
    assert spec.names[-2:] == ("goal.colour=blue", "goal.colour=red")
    x = scene_to_graph(bins, spec).x
    own = [column(spec, "goal.colour=blue"), column(spec, "goal.colour=red")]
    assert x[2, own].tolist() == [1.0, 0.0]  # bin_0 is blue
    assert x[3, own].tolist() == [0.0, 0.0] and x[0, own].tolist() == [0.0, 0.0]
    assert x[2, column(spec, "colour:any")] == 1  # being blue is not accepting only blue
    assert bool(task.admits(x[:2], x[2:]).all())
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", features=spec))
    path = save_checkpoint(tmp_path / "bins.pt", net, training_config={}, data_hash="h")
    loaded, _ = load_checkpoint(path, message_passing=False)
    assert loaded.config.feature_spec == spec
    assert torch.load(path, weights_only=True)["feature_spec"]["task"]["goal_attributes"] == [
        "colour"
    ]


def test_text_and_numbers_for_one_attribute_cannot_be_learned() -> None:
    mixed = scene([obj("a", 0.4, colour="red"), obj("b", 0.5, colour=3.0)], [goal("g", 0.4)])
    with pytest.raises(ValueError, match="attribute colour: text on some"):
        TaskFeatures.learn([mixed])


def task_checkpoint(tmp_path: Path) -> tuple[Path, FeatureSpec]:
    spec = FeatureSpec.for_task(TaskFeatures.learn([COLOURS]))
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", features=spec))
    path = save_checkpoint(tmp_path / "task.pt", net, training_config={}, data_hash="h")
    return path, spec


def test_the_task_spec_is_stamped_and_the_policy_builds_graphs_with_it(tmp_path: Path) -> None:
    path, spec = task_checkpoint(tmp_path)
    stamped = torch.load(path, weights_only=True)["feature_spec"]
    assert stamped["task"]["attributes"][0] == {"name": "colour", "vocabulary": ["blue", "red"]}
    assert "features" not in torch.load(path, weights_only=True)["model"]
    net, _info = load_checkpoint(path, message_passing=False)
    assert net.config.feature_spec == spec and net.config.input_size == spec.num_features
    policy = load_policy(str(path))
    assert isinstance(policy, GNNPolicy)
    assert policy.decide(COLOURS) is not None
    assert "goal_attributes" not in stamped["task"]  # no goal carries one: the stamp of before


def test_a_tampered_task_stamp_is_refused_naming_the_field(tmp_path: Path) -> None:
    path, _ = task_checkpoint(tmp_path)
    payload = torch.load(path, weights_only=True)
    payload["feature_spec"]["task"]["attributes"][0]["vocabulary"] = ["blue", "red", "green"]
    torch.save(payload, path)
    with pytest.raises(PolicyError, match=r"checkpoint feature_spec\.names: do not match"):
        load_checkpoint(path)
    payload["feature_spec"]["task"]["attributes"][0] = {"name": "colour"}
    torch.save(payload, path)
    with pytest.raises(PolicyError, match=r"checkpoint feature_spec\.task\.attributes\.colour"):
        load_checkpoint(path)


@pytest.mark.parametrize("name", ["sage.pt", "gcn.pt", "gated.pt", "gat.pt"])
def test_the_shipped_block_checkpoints_load_with_the_papers_spec(name: str) -> None:
    net, info = load_checkpoint(REPO / "checkpoints" / name)
    assert net.config.feature_spec is FEATURE_SPEC
    assert "task" not in info.feature_spec


@pytest.mark.parametrize("name", ["dishwasher-left-right-sage.pt", "dishwasher-top-bottom-sage.pt"])
def test_the_shipped_dishwasher_checkpoints_load_with_their_own_spec(name: str) -> None:
    net, info = load_checkpoint(REPO / "checkpoints" / name)
    assert net.config.heads == "dishwasher" and net.config.features is None
    assert "task" not in info.feature_spec


def test_a_task_policy_takes_only_pairs_whose_goal_accepts_the_object(tmp_path: Path) -> None:
    path, _ = task_checkpoint(tmp_path)
    policy = load_policy(str(path))
    assert {d.pair for d in policy.ranked(COLOURS)} == {
        ("block_0", "red_slot"),
        ("block_0", "any_slot"),
        ("block_1", "any_slot"),
        ("block_1", "part"),
    }


def test_the_accepts_filter_turned_off_leaves_the_networks_own_choice(tmp_path: Path) -> None:
    path, _ = task_checkpoint(tmp_path)
    policy = load_policy(str(path), accepts_filter="off")
    assert policy.accepts_filter is False
    pairs = {d.pair for d in policy.ranked(COLOURS)}
    assert len(pairs) == 6 and ("block_1", "red_slot") in pairs  # 2 blocks x 3 block goals
    assert load_policy(str(path)).accepts_filter is True
    with pytest.raises(PolicyError, match="'expert' has no accepts filter to turn off"):
        load_policy("expert", accepts_filter="off")
    with pytest.raises(PolicyError, match="no accepts filter"):
        load_policy(str(REPO / "checkpoints" / "sage.pt"), accepts_filter="off")
