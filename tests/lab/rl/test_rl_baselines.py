"""Each baseline's PPO training step, and RL-GNN-demo's imitation term."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.rl.baselines import BASELINES, PPOSettings, Stage, load_model, train_stage
from manigraph_lab.rl.imitation import ImitationAdam, ImitationTerm
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import ConfigError
from manigraph_training.dataset import Sample, load_demonstrations

TINY = PPOSettings(
    steps_per_stage=16, n_steps=16, batch_size=8, n_epochs=1, blocks=(2, 3), hidden_channels=8
)


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory) -> list[Sample]:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(("box-pack",), (3,), 2, 0), path)
    return load_demonstrations([path]).samples


def _parameters(path: Path, baseline: str, stage: Stage) -> dict[str, torch.Tensor]:
    model = load_model(path, BASELINES[baseline].make_env(stage, TINY))
    return {k: v.clone() for k, v in model.policy.state_dict().items()}


@pytest.mark.parametrize("name", ["rl-mlp", "rl-gnn", "rl-gnn-seq", "rl-gnn-demo"])
def test_one_ppo_update_changes_the_policy(name: str, tmp_path: Path, demos: list[Sample]) -> None:
    baseline = BASELINES[name]
    first, second = baseline.stages(TINY)[:2]
    record = train_stage(baseline, first, TINY, 0, None, tmp_path / "a.zip", lambda: demos)
    assert record["timesteps"] == 16 and record["total_timesteps"] == 16
    before = _parameters(tmp_path / "a.zip", name, first)
    start = tmp_path / "a.zip" if baseline.continues else None
    record = train_stage(baseline, second, TINY, 0, start, tmp_path / "b.zip", lambda: demos)
    after = _parameters(tmp_path / "b.zip", name, second)
    assert record["total_timesteps"] == (32 if baseline.continues else 16)
    assert before.keys() == after.keys()
    changed = [k for k in before if not torch.equal(before[k], after[k])]
    assert changed, f"{name}: no parameter changed"
    if name == "rl-gnn-demo":
        assert record["imitation_loss_first"] is not None
    else:
        assert "imitation_loss_first" not in record


def test_imitation_term_alone_lowers_the_experts_cross_entropy(demos: list[Sample]) -> None:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", hidden_channels=16, num_layers=2))
    optimizer = ImitationAdam(net.parameters(), lr=1e-2)
    optimizer.imitation = ImitationTerm(net, demos, weight=1.0, batch_size=len(demos))
    with torch.no_grad():
        start = float(optimizer.imitation.loss())
    for _ in range(30):
        optimizer.zero_grad()  # no PPO gradient: the step follows the imitation term only
        optimizer.step()
    with torch.no_grad():
        end = float(optimizer.imitation.loss())
    assert end < 0.75 * start


def test_zero_weight_imitation_is_plain_adam(demos: list[Sample]) -> None:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", hidden_channels=8, num_layers=1))
    before = [p.clone() for p in net.parameters()]
    optimizer = ImitationAdam(net.parameters(), lr=1e-2)
    optimizer.imitation = ImitationTerm(net, demos, weight=0.0)
    optimizer.zero_grad()
    optimizer.step()
    assert all(torch.equal(a, b) for a, b in zip(before, net.parameters(), strict=True))


def test_settings_are_validated_naming_the_field() -> None:
    with pytest.raises(ConfigError, match="steps_per_stage"):
        PPOSettings(steps_per_stage=300, n_steps=250)
    with pytest.raises(ConfigError, match="architecture"):
        PPOSettings(architecture="transformer")
    with pytest.raises(ConfigError, match="imitation_weight"):
        PPOSettings(imitation_weight=-1.0)
