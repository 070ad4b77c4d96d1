"""``manigraph demos --tasks shelf`` records the shelf family's expert; ``manigraph train``
teaches the generic object-goal network from them, and it fills a larger shelf."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_shared.cli import main
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene
from manigraph_shelf.planner.expert import ShelfExpert
from manigraph_shelf.shelf_geometry import BACK, FRONT, ROW_ATTRIBUTE


def _json(capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    return dict(json.loads(capsys.readouterr().out.strip().splitlines()[-1]))


def test_demos_record_the_shelf_expert_and_train_teaches_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log, checkpoint = tmp_path / "shelf.mcap", tmp_path / "sage.pt"
    argv = ["demos", "--tasks", "shelf", "--objects", "4", "--trajectories", "8"]
    assert main([*argv, "--seed", "53930", "-o", str(log)]) == 0
    assert _json(capsys)["decisions"] == 8 * 4

    scenes: dict[tuple[str, int], Scene] = {}  # sequences start again per episode
    actions: list[Action] = []
    for item in read_log(log, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            scenes[message.episode_id, message.sequence] = message
        elif isinstance(message, Action):
            actions.append(message)
    expert = ShelfExpert()
    for action in actions:
        scene = scenes[action.episode_id, action.scene_sequence]
        decision = expert.decide(scene)
        assert action.policy == "shelf-expert" and decision is not None
        assert (action.object_id, action.goal_id) == decision.pair
    rows = [
        scenes[a.episode_id, a.scene_sequence].goal(a.goal_id).attributes[ROW_ATTRIBUTE]
        for a in actions
    ]
    assert rows == [BACK, BACK, FRONT, FRONT] * 8

    train = ["train", str(log), "--arch", "sage", "--epochs", "3", "-o", str(checkpoint)]
    assert main(train) == 0
    assert "goal.shelf_row=back" in _json(capsys)["features"]  # type: ignore[operator]
    evaluate = ["eval", "--policy", str(checkpoint), "--task", "shelf", "--objects", "8"]
    assert main([*evaluate, "--seed", "53940", "--episodes", "10", "--json"]) == 0
    assert _json(capsys)["success_rate"] == 1.0
