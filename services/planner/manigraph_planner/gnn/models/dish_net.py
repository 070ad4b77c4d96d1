r"""The dishwasher's four-headed policy network (paper, section 'Dishwasher loading').

The backbone and node head of :class:`PolicyNet` (object and goal logits), plus

.. math::
    r_i = W_r h_i + b_r \in \mathbb{R}^6, \qquad
    t = W_t\,[\mathrm{mean}_i h_i \,\|\, \max_i h_i] + b_t \in \mathbb{R}^3

an orientation head read at the chosen object's node (which of six discrete orientations to
place it in) and a tray head on the pooled graph (toggle top, toggle bottom, none). Reading
the orientation at the object's node, rather than from the pooled graph, ties it to the dish
the object head picks; the paper's four categorical outputs are otherwise the same.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
from torch import Tensor, nn

from manigraph_planner.gnn.models.config import ModelConfig
from manigraph_planner.gnn.models.policy_net import PolicyNet
from manigraph_shared.orientations import NUM_ORIENTATIONS

__all__ = ["DishHeads", "DishPolicyNet", "NUM_TRAY_ACTIONS"]

NUM_TRAY_ACTIONS = 3


class DishHeads(NamedTuple):
    """Shapes: node :math:`(B, N)`, orientation :math:`(B, N, 6)`, tray :math:`(B, 3)`
    (without the batch dimension for one graph)."""

    node: Tensor
    orientation: Tensor
    tray: Tensor


class DishPolicyNet(PolicyNet):
    def __init__(self, config: ModelConfig) -> None:
        super().__init__(config)
        hidden = config.hidden_channels
        self.orientation_head = nn.Linear(hidden, NUM_ORIENTATIONS)
        self.tray_head = nn.Linear(2 * hidden, NUM_TRAY_ACTIONS)

    def heads_complete(self, x: Tensor, mask: Tensor | None = None) -> DishHeads:
        """The four heads' logits for one graph :math:`(N, F)` or a padded batch
        :math:`(B, N_{max}, F)` with ``mask`` :math:`(B, N_{max})`."""
        single = x.dim() == 2
        if single:
            x = x.unsqueeze(0)
            mask = torch.ones(x.shape[:2], dtype=torch.bool)
        assert mask is not None
        hidden = self.backbone.forward_complete(x * self.feature_scale, mask)
        real = mask.unsqueeze(-1)
        count = real.sum(dim=1).clamp(min=1)
        mean = hidden.masked_fill(~real, 0).sum(dim=1) / count
        peak = hidden.masked_fill(~real, float("-inf")).amax(dim=1)
        heads = DishHeads(
            self.head(hidden).squeeze(-1),
            self.orientation_head(hidden),
            self.tray_head(torch.cat([mean, peak], dim=-1)),
        )
        if single:
            return DishHeads(*(h.squeeze(0) for h in heads))
        return heads


def policy_net_for(config: ModelConfig) -> PolicyNet:
    """The network class ``config.heads`` asks for."""
    return DishPolicyNet(config) if config.heads == "dishwasher" else PolicyNet(config)
