r"""Policies for PPO: the planner's GNN as an actor-critic, and any trained model as a ``Policy``.

The GNN baselines use the IL policy's own network, a
:class:`~manigraph_planner.gnn.models.PolicyNet` (registered backbone + one-logit node head),
as the features extractor of ``sb3_contrib``'s maskable actor-critic. Its node logits
:math:`v` give the logit of the pair (object :math:`o`, goal :math:`g`)

.. math::
    \ell_{o,g} = v_o + v_g,

so a softmax over the allowed pairs is the IL policy's :math:`p(o)\,p(g)` restricted to
compatible pairs, its mode is the IL decoder's decision
(:func:`~manigraph_planner.policies.gnn.best_compatible_pair`), and the trained network can be
served, evaluated and explained as a :class:`~manigraph_planner.policies.gnn.GNNPolicy`. The
critic reads the mean of the real nodes' hidden states through one linear layer.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium
import torch
from sb3_contrib import MaskablePPO
from sb3_contrib.common.maskable.policies import MaskableMultiInputActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import Tensor, nn

from manigraph_lab.rl.env import SlotLayout
from manigraph_planner.gnn.features import scene_to_graph
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies.base import Decision, Policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.messages import Scene

__all__ = ["GraphActorCriticPolicy", "GraphFeatures", "MaskablePPOPolicy", "policy_net"]


class GraphFeatures(BaseFeaturesExtractor):
    """A :class:`PolicyNet` on the env's slotted graph: pair logits, then the pooled state.

    Args:
        observation_space: the env's ``Dict`` space (``nodes``, ``node_mask``), objects in the
            first half of the slots, goals in the second.
        architecture, hidden_channels, num_layers: the :class:`ModelConfig` of the network.

    Shapes:
        - **output:** :math:`(B, M^2 + H)`: the :math:`M \times M` pair logits (row-major, as
          the env's action index), then the :math:`H` pooled hidden channels
    """

    def __init__(
        self,
        observation_space: gymnasium.spaces.Dict,
        architecture: str = "sage",
        hidden_channels: int = 64,
        num_layers: int = 3,
    ) -> None:
        nodes = observation_space["nodes"].shape[0]  # type: ignore[index]
        self.max_objects = nodes // 2
        super().__init__(observation_space, self.max_objects**2 + hidden_channels)
        self.net = PolicyNet(ModelConfig(architecture, hidden_channels, num_layers))

    def forward(self, observations: dict[str, Tensor]) -> Tensor:
        x, mask = observations["nodes"], observations["node_mask"] > 0.5
        hidden = self.net.backbone.forward_complete(x * self.net.feature_scale, mask)
        logits = self.net.head(hidden).squeeze(-1)
        m = self.max_objects
        pairs = (logits[:, :m].unsqueeze(2) + logits[:, m:].unsqueeze(1)).flatten(1)
        weights = mask.unsqueeze(-1).to(hidden.dtype)
        pooled = (hidden * weights).sum(1) / weights.sum(1).clamp(min=1.0)
        return torch.cat([pairs, pooled], dim=1)


class _Columns(nn.Module):
    """Columns ``start:stop`` of the features: the action logits, or the critic's input."""

    def __init__(self, start: int, stop: int) -> None:
        super().__init__()
        self.start, self.stop = start, stop

    def forward(self, features: Tensor) -> Tensor:
        return features[:, self.start : self.stop]


class GraphActorCriticPolicy(MaskableMultiInputActorCriticPolicy):
    """Maskable actor-critic whose actor is the GNN's pair logits, unchanged (no extra layers),
    and whose critic is one linear layer on the pooled hidden state. Actor and critic share
    the GNN. Network kwargs go to :class:`GraphFeatures` via ``features_extractor_kwargs``."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("features_extractor_class", GraphFeatures)
        kwargs["net_arch"] = {"pi": [], "vf": []}  # no MLP between the GNN and the heads
        kwargs["ortho_init"] = False  # keep the PolicyNet's own initialisation
        super().__init__(*args, **kwargs)

    def _build(self, lr_schedule: Any) -> None:
        self._build_mlp_extractor()
        actions = int(self.action_space.n)  # type: ignore[attr-defined]
        self.action_net = _Columns(0, actions)
        self.value_net = nn.Sequential(  # type: ignore[assignment]
            _Columns(actions, self.features_dim), nn.Linear(self.features_dim - actions, 1)
        )
        self.optimizer = self.optimizer_class(
            self.parameters(),
            lr=lr_schedule(1),  # type: ignore[call-arg]
            **self.optimizer_kwargs,
        )


def policy_net(model: MaskablePPO) -> PolicyNet:
    """The GNN inside a model trained with :class:`GraphActorCriticPolicy`."""
    extractor = model.policy.features_extractor
    if not isinstance(extractor, GraphFeatures):
        raise TypeError("policy_net: the model's policy is not a GraphActorCriticPolicy")
    return extractor.net


def as_gnn_policy(model: MaskablePPO) -> GNNPolicy:
    """A copy of the model's GNN as the planner's policy (same decisions as the model's
    deterministic action; evaluable and explainable like an IL checkpoint)."""
    return GNNPolicy(copy.deepcopy(policy_net(model)).cpu())


class MaskablePPOPolicy(Policy):
    """Any trained maskable model as a planner ``Policy``: a scene is encoded as the env
    encodes it and the model's deterministic action becomes the decision.

    Args:
        model: the trained model.
        layout: the slots of the env it was trained on.
        name: the policy's name in evaluation summaries.
    """

    def __init__(self, model: MaskablePPO, layout: SlotLayout, name: str) -> None:
        self.model = model
        self.layout = layout
        self.name = name

    def decide(self, scene: Scene) -> Decision | None:
        graph = scene_to_graph(scene)
        observation, mask = self.layout.encode(graph)
        if not mask.any():
            return None
        action, _ = self.model.predict(observation, action_masks=mask, deterministic=True)
        o, g = self.layout.pair(int(action))
        return Decision(graph.object_ids[o], graph.goal_ids[g])
