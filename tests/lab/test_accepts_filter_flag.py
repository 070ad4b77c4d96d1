"""``--accepts-filter off`` on eval, the planner and up: the network judged alone (issue #49)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest
import torch

from manigraph_planner.gnn.checkpoint import save_checkpoint
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import AttributeColumns, TaskFeatures
from manigraph_shared.cli import main
from manigraph_tools.stack_processes import planner_argv

REPO = Path(__file__).resolve().parents[2]
COLOUR_SORT = REPO / "examples" / "tasks" / "colour-sort.toml"


def colour_checkpoint(tmp_path: Path) -> Path:
    spec = FeatureSpec.for_task(TaskFeatures((AttributeColumns("colour", ("blue", "red")),)))
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", features=spec))
    return save_checkpoint(tmp_path / "colour.pt", net, training_config={}, data_hash="h")


def eval_summary(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict:
    common = ["--task-file", str(COLOUR_SORT), "--episodes", "2", "--seed", "5000", "--json"]
    assert main(["eval", *argv, *common]) == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_eval_says_which_filter_judged_the_policy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = str(colour_checkpoint(tmp_path))
    filtered = eval_summary(["--policy", path], capsys)
    alone = eval_summary(["--policy", path, "--accepts-filter", "off"], capsys)
    assert filtered["accepts_filter"] == "on" and alone["accepts_filter"] == "off"
    # An untrained network sends blocks to bins of the other colour once nothing stops it.
    assert filtered["wrong_object"] == 0 and alone["wrong_object"] > 0


def test_a_policy_without_the_filter_cannot_turn_it_off(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["eval", "--policy", "expert", "--accepts-filter", "off", "--episodes", "1"]
    assert main(argv) != 0
    assert "'expert' has no accepts filter to turn off" in capsys.readouterr().err


def test_up_passes_the_switch_to_its_planner() -> None:
    args = argparse.Namespace(policy="p.pt", explain_decisions=False, accepts_filter="off")
    assert planner_argv(args, None)[-2:] == ["--accepts-filter", "off"]
    args.accepts_filter = "on"
    assert "--accepts-filter" not in planner_argv(args, None)
