"""``manigraph demos --tasks dishwasher`` records the dishwasher family's expert."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_dishwasher.planner.expert import LeftRightExpert, TopBottomExpert
from manigraph_planner.policies import Policy
from manigraph_shared.cli import main
from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene


@pytest.mark.parametrize(
    ("flags", "expert", "dishes"),
    [
        ([], TopBottomExpert(), 10),  # no preference: the sim lays out top-bottom, 10 dishes
        (["--objects", "4", "--preference", "left-right"], LeftRightExpert(), 4),
    ],
    ids=["defaults", "left-right"],
)
def test_demos_of_the_dishwasher_record_its_expert_s_decisions(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    flags: list[str],
    expert: Policy,
    dishes: int,
) -> None:
    log = tmp_path / "dishwasher.mcap"
    argv = ["demos", "--tasks", "dishwasher", "--trajectories", "1", *flags, "-o", str(log)]
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
    assert len(scenes[actions[0].scene_sequence].objects) == dishes
    for action in actions:
        assert action.policy == expert.name
        decision = expert.decide(scenes[action.scene_sequence])
        assert decision is not None
        assert (action.object_id, action.goal_id, action.family_action) == (
            decision.object_id,
            decision.goal_id,
            decision.family_action,
        )
    # Each dish placed once; a rack pulled out and pushed back in per rack it loads.
    trays = sum(a.family_action == "toggle" for a in actions)
    assert len(actions) - trays == dishes and trays == (4 if expert.name.endswith("bottom") else 2)


def test_demos_refuse_dishes_for_a_block_task_naming_the_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["demos", "--tasks", "stack", "--trajectories", "1", "--objects", "4"]
    assert main([*argv, "-o", str(tmp_path / "x.mcap")]) == CONFIG_EXIT_CODE
    assert "objects" in capsys.readouterr().err
