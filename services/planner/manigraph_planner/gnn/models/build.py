"""The network a :class:`ModelConfig` asks for, by its heads: the block policy's
:class:`PolicyNet`, or the network its task family registers for its heads (heads of its
own, an ensemble of them).

A network with message passing is built from PyG's layers, which the serving planner does not
install (it serves with the layers' weights alone, by dense algebra); training installs PyG
(``manigraph-training``)."""

from __future__ import annotations

from manigraph_planner.family import family_for_heads
from manigraph_planner.gnn.models.config import ModelConfig
from manigraph_planner.gnn.models.policy_net import PolicyNet
from manigraph_shared.errors import PolicyError

__all__ = ["policy_net_for", "require_message_passing", "with_message_passing"]


def policy_net_for(config: ModelConfig, message_passing: bool = True) -> PolicyNet:
    """The network class ``config`` asks for: the paper's :class:`PolicyNet`, or the network
    of the family whose heads ``config`` has (``PlannerFamily.network``: a network with heads
    of its own, or an ensemble of them). ``message_passing``: see :class:`PolicyNet`."""
    network = family_for_heads(config.heads).part("network")
    if network is None:
        return PolicyNet(config, message_passing)
    net: PolicyNet = network(config, message_passing)
    return net


def with_message_passing(net: PolicyNet) -> PolicyNet:
    """``net`` itself if it can pass messages, else the PyG network of its config holding
    a copy of its weights (what the explainer's edge masks need)."""
    if net.message_passing:
        return net
    require_message_passing()
    twin = policy_net_for(net.config, message_passing=True)
    twin.load_state_dict(net.state_dict(), strict=True)
    return twin.train(net.training)


def require_message_passing() -> None:
    """Raises ``PolicyError`` naming what is missing where PyG (the layers that pass messages)
    is not installed: the serving planner does not carry it."""
    try:
        import torch_geometric  # noqa: F401
    except ImportError:
        raise PolicyError(
            "message passing: this network needs PyG's layers (torch-geometric), which the "
            "serving planner does not install; install manigraph-training, which brings them"
        ) from None
