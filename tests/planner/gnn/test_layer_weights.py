"""Weights-only layers hold exactly PyG's parameters, and refuse message passing by name."""

from __future__ import annotations

import pytest
import torch

from manigraph_planner.gnn.features import fully_connected_edge_index
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_planner.gnn.models.build import policy_net_for, with_message_passing
from manigraph_shared.errors import PolicyError

ARCHS = sorted(ARCHITECTURES.names())


@pytest.mark.parametrize("arch", ARCHS)
@pytest.mark.parametrize("heads", ["object-goal", "dishwasher"])
def test_weights_only_networks_have_pyg_s_parameters_name_for_name(arch: str, heads: str) -> None:
    config = ModelConfig(arch, heads=heads)
    pyg, weights = policy_net_for(config, True), policy_net_for(config, False)
    expected = {k: tuple(v.shape) for k, v in pyg.state_dict().items()}
    assert {k: tuple(v.shape) for k, v in weights.state_dict().items()} == expected
    weights.load_state_dict(pyg.state_dict(), strict=True)  # and back, below
    rebuilt = with_message_passing(weights)
    assert rebuilt.message_passing and not weights.message_passing
    x = torch.randn(6, config.input_size)
    with torch.no_grad():
        assert torch.allclose(rebuilt.forward_complete(x), weights.forward_complete(x), atol=1e-6)
        message_passing = rebuilt(x, fully_connected_edge_index(6))
    assert torch.allclose(message_passing, weights.forward_complete(x), atol=1e-4)


def test_a_weights_only_network_refuses_message_passing_by_name() -> None:
    net = PolicyNet(ModelConfig("sage"), message_passing=False)
    with pytest.raises(PolicyError, match=r"SAGEWeights.*message passing"):
        net(torch.randn(3, 5), fully_connected_edge_index(3))


def test_a_network_that_passes_messages_is_its_own_message_passing_network() -> None:
    net = PolicyNet(ModelConfig("gat"))
    assert with_message_passing(net) is net
