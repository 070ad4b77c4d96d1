"""Where training runs is checked when the config is made, naming the field."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import ConfigError
from manigraph_training.dataset import load_demonstrations
from manigraph_training.trainer import TrainConfig, train


@pytest.mark.parametrize("device", ["gpu", "cuda:x", "cpu:0"])
def test_a_device_that_is_not_one_is_refused(device: str) -> None:
    with pytest.raises(ConfigError, match=r"^device: .* is not cpu, cuda or cuda:N"):
        TrainConfig(device=device)


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a CUDA device")
def test_cuda_without_a_cuda_device_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="device: cuda: torch sees no CUDA device"):
        TrainConfig(device="cuda")


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_training_returns_a_cpu_network(tmp_path: Path) -> None:
    path = tmp_path / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=2), path, progress=None)  # type: ignore[arg-type]
    net, metrics = train(load_demonstrations([path]), TrainConfig(device="cuda", epochs=2))
    assert next(net.parameters()).device.type == "cpu" and metrics["device"] == "cuda"
