"""``manigraph train --epochs 0`` writes the untrained baseline a learned figure stands beside
(docs/results policy): the network as a trained run of that seed starts, its config, and a note
in the checkpoint that it is untrained; the generic trainer and the dishwasher's alike. The
generic trainer draws its augmentation from the recipes of the demonstrations' family."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from manigraph_planner.gnn import load_checkpoint
from manigraph_planner.gnn.models import PolicyNet
from manigraph_shared.cli import main
from manigraph_shared.errors import ConfigError
from manigraph_training.trainer import TrainConfig


def _last_json(capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    return dict(json.loads(capsys.readouterr().out.strip().splitlines()[-1]))


def _demos(path: Path, *argv: str) -> Path:
    assert main(["demos", *argv, "--trajectories", "2", "--seed", "53450", "-o", str(path)]) == 0
    return path


def test_zero_epochs_writes_the_network_a_trained_run_starts_from(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    demos = _demos(tmp_path / "stack.mcap", "--tasks", "stack", "--blocks", "3")
    checkpoint = tmp_path / "gcn-untrained.pt"
    argv = ["train", str(demos), "--arch", "gcn", "--seed", "7", "--epochs", "0"]
    assert main([*argv, "-o", str(checkpoint)]) == 0
    printed = _last_json(capsys)
    assert printed["untrained"] is True and printed["final_loss"] is None

    net, info = load_checkpoint(checkpoint)
    assert info.metrics is not None and info.metrics["untrained"] is True
    assert info.training_config["epochs"] == 0 and info.training_config["family"] == "blocks"
    torch.manual_seed(7)  # what the trainer seeds before it builds the network
    start = PolicyNet(TrainConfig(architecture="gcn", seed=7).model_config())
    for name, weights in start.state_dict().items():
        assert torch.equal(net.state_dict()[name], weights), name

    # The baseline is a policy like any other: eval plays it.
    evaluate = ["eval", "--policy", str(checkpoint), "--task", "stack", "--blocks", "3"]
    assert main([*evaluate, "--episodes", "1", "--seed", "53460", "--json"]) == 0
    assert _last_json(capsys)["policy"] == "gnn-gcn"


def test_the_dishwasher_trainer_writes_its_untrained_ensemble_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    demos = _demos(tmp_path / "dishes.mcap", "--tasks", "dishwasher", "--objects", "4")
    checkpoint = tmp_path / "dish-untrained.pt"
    argv = ["train", str(demos), "--arch", "gcn", "--epochs", "0", "-o", str(checkpoint)]
    assert main(argv) == 0
    printed = _last_json(capsys)
    assert printed["heads"] == "dishwasher" and printed["untrained"] is True
    assert printed["final_loss"] == [None, None, None]  # no loss taken by any member
    _, info = load_checkpoint(checkpoint)
    assert info.metrics is not None and info.metrics["untrained"] is True
    assert info.training_config["epochs"] == 0


def test_negative_epochs_are_refused_naming_the_field() -> None:
    with pytest.raises(ConfigError, match=r"epochs: must be >= 0"):
        TrainConfig(epochs=-1)
    assert TrainConfig(epochs=0).epochs == 0
