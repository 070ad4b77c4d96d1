"""``manigraph demos --tasks dishwasher`` records the dishwasher family's expert."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_planner.families.dishwasher.expert import TopBottomExpert
from manigraph_shared.cli import main
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene, TrayAction


def test_demos_of_the_dishwasher_record_its_expert_s_decisions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "dishwasher.mcap"
    argv = ["demos", "--tasks", "dishwasher", "--trajectories", "1", "-o", str(log)]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["trajectories"] == 1 and summary["decisions"] > 0

    scenes: dict[int, Scene] = {}
    actions: list[Action] = []
    for item in read_log(log, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            scenes[message.sequence] = message
        elif isinstance(message, Action):
            actions.append(message)
    assert len(actions) == summary["decisions"]
    expert = TopBottomExpert()  # the request sets no preference: the sim lays out top-bottom
    for action in actions:
        assert action.policy == "dishwasher-top-bottom"
        decision = expert.decide(scenes[action.scene_sequence])
        assert decision is not None
        assert (action.object_id, action.goal_id, action.tray_action) == (
            decision.object_id,
            decision.goal_id,
            decision.tray_action,
        )
    # Both racks were pulled out and pushed back in: four tray actions, the rest dishes.
    assert sum(a.tray_action is not TrayAction.NONE for a in actions) == 4
