"""A task taught without code: demos of a task file, a policy trained on them, evaluated."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from manigraph_shared.cli import main
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene

#: Two red and two blue blocks, colours shuffled per episode, into slots that say which.
COLOUR_SORT = """
name = "tiny colour sort"
shuffle = ["colour"]

[[objects]]
id = "block_0"
category = "block"
position = [0.40, -0.20, 0.02]
attributes = { colour = "red" }

[[objects]]
id = "block_1"
category = "block"
position = [0.50, -0.20, 0.02]
attributes = { colour = "blue" }

[[objects]]
id = "block_2"
category = "block"
position = [0.60, -0.20, 0.02]
attributes = { colour = "red" }

[[goals]]
id = "red_slot"
category = "block"
position = [0.45, 0.15, 0.02]
accepts = { colour = "red" }

[[goals]]
id = "blue_slot"
category = "block"
position = [0.55, 0.15, 0.02]
accepts = { colour = "blue" }
"""


def test_demos_of_a_task_file_train_a_policy_with_its_columns_that_eval_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    task = tmp_path / "colour-sort.toml"
    task.write_text(COLOUR_SORT)
    demos, model = tmp_path / "demos.mcap", tmp_path / "model.pt"
    argv = ["demos", "--task-file", str(task), "--trajectories", "4", "--seed", "7"]
    assert main([*argv, "-o", str(demos)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["trajectories"] == 4 and summary["decisions"] == 8  # two goals each

    pairs: dict[tuple[str, int], Scene] = {}
    actions: list[Action] = []
    for item in read_log(demos, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            pairs[(message.episode_id, message.sequence)] = message
        elif isinstance(message, Action):
            actions.append(message)
    for action in actions:  # the expert sent every block to a slot of its colour
        scene = pairs[(action.episode_id, action.scene_sequence)]
        colour = next(o for o in scene.objects if o.id == action.object_id).attributes["colour"]
        assert action.goal_id == f"{colour}_slot"

    train = ["train", str(demos), "--arch", "sage", "--epochs", "3", "--copies", "1"]
    assert main([*train, "-o", str(model)]) == 0
    trained = json.loads(capsys.readouterr().out)
    assert trained["features"][5:] == [
        "size_x",
        "size_y",
        "size_z",
        "size:any",
        "colour=blue",
        "colour=red",
        "colour:any",
    ]
    stamped = torch.load(model, weights_only=True)["feature_spec"]["task"]
    assert stamped["attributes"] == [{"name": "colour", "vocabulary": ["blue", "red"]}]

    evaluate = ["eval", "--policy", str(model), "--task-file", str(task), "--episodes", "3"]
    assert main([*evaluate, "--seed", "900", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["episodes"] == 3 and result["task_file"] == "colour-sort"
    # Whatever three epochs learned, a block only ever went to a slot of its colour.
    assert result["goals_filled_rate"] > 0


def test_demos_refuse_a_task_file_its_objects_cannot_satisfy_before_any_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    task = tmp_path / "bad.toml"
    task.write_text(
        COLOUR_SORT.replace('accepts = { colour = "blue" }', 'accepts = { colour = "green" }')
    )
    assert main(["demos", "--task-file", str(task), "-o", str(tmp_path / "d.mcap")]) != 0
    assert "green" in capsys.readouterr().err
    assert not (tmp_path / "d.mcap").exists()
