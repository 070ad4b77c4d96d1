"""FlatAdam updates the weights exactly as torch.optim.Adam does, bit for bit."""

from __future__ import annotations

import pytest
import torch

from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_training.flat_adam import FlatAdam


def twin_nets(arch: str) -> tuple[PolicyNet, PolicyNet]:
    torch.manual_seed(0)
    reference = PolicyNet(ModelConfig(arch), message_passing=False)
    twin = PolicyNet(ModelConfig(arch), message_passing=False)
    twin.load_state_dict(reference.state_dict())
    return reference, twin


def train_steps(net: PolicyNet, optimiser: torch.optim.Optimizer, steps: int) -> None:
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, T_max=steps)
    generator = torch.Generator().manual_seed(1)
    mask = torch.arange(11) < torch.tensor([[11], [7], [3]])
    for _ in range(steps):
        x = torch.randn(3, 11, 5, generator=generator)
        logits = net.forward_complete(x, mask)
        loss = logits[mask].square().mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        schedule.step()


@pytest.mark.parametrize("weight_decay", [0.0, 1e-3])
@pytest.mark.parametrize("arch", sorted(ARCHITECTURES))
def test_flat_adam_gives_the_weights_torch_adam_gives(arch: str, weight_decay: float) -> None:
    reference, twin = twin_nets(arch)
    train_steps(
        reference, torch.optim.Adam(reference.parameters(), 3e-3, weight_decay=weight_decay), 40
    )
    flat = FlatAdam(twin.parameters(), 3e-3, weight_decay=weight_decay)
    train_steps(twin, flat, 40)
    flat.unflatten()
    got_state = twin.state_dict()
    for name, expected in reference.state_dict().items():
        got = got_state[name]
        assert torch.equal(got, expected), name
        assert got.untyped_storage().nbytes() == got.numel() * got.element_size(), name


def test_flat_adam_refuses_a_step_without_every_gradient() -> None:
    net = torch.nn.Linear(3, 2)
    optimiser = FlatAdam(net.parameters())
    net(torch.ones(1, 3)).sum().backward()
    net.bias.grad = None
    with pytest.raises(RuntimeError, match=r"parameters \[1\] got no gradient"):
        optimiser.step()
