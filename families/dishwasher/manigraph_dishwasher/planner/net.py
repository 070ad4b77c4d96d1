r"""The dishwasher's four-headed policy network (paper, section 'Dishwasher loading').

The backbone and node head of :class:`PolicyNet` (object and goal logits), plus

.. math::
    r_i = W_r h_i + b_r \in \mathbb{R}^6, \qquad
    t = \big[\,u(h_{top} \| \bar h),\; u(h_{bottom} \| \bar h),\;
        \max_{i \in \mathrm{dishes}} w(h_i \| \bar h)\,\big], \qquad
    \bar h = [\mathrm{mean}_i h_i \,\|\, \max_i h_i]

an orientation head read at the chosen object's node (which of six discrete orientations to
place it in) and a tray head (toggle top, toggle bottom, none) that scores each rack at its
own node, with the pooled graph as context, and "none" (PickAndPlace) as the best score of
a dish scored at its node (:meth:`DishPolicyNet._place_score`): "a dish can be placed now".
Reading the orientation at the object's node and a toggle at the rack's node ties them to
the node they act on (as the object and goal heads are); the paper's four categorical outputs
are
otherwise the same.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
from torch import Tensor, nn

from manigraph_dishwasher.planner.features import DISH_FEATURE_SPEC
from manigraph_planner.gnn.models.config import ModelConfig
from manigraph_planner.gnn.models.policy_net import PolicyNet
from manigraph_shared.orientations import NUM_ORIENTATIONS

__all__ = ["NUM_TRAY_ACTIONS", "DishHeads", "DishPolicyNet"]

NUM_TRAY_ACTIONS = 3
RACK_TOP_COLUMN = DISH_FEATURE_SPEC.names.index("is-rack-top")
RACK_BOTTOM_COLUMN = DISH_FEATURE_SPEC.names.index("is-rack-bottom")
DISH_COLUMNS = [DISH_FEATURE_SPEC.names.index("is-plate"), DISH_FEATURE_SPEC.names.index("is-bowl")]


class DishHeads(NamedTuple):
    """Shapes: node :math:`(B, N)`, orientation :math:`(B, N, 6)`, tray :math:`(B, 3)`
    (without the batch dimension for one graph)."""

    node: Tensor
    orientation: Tensor
    tray: Tensor


class DishPolicyNet(PolicyNet):
    def __init__(self, config: ModelConfig, message_passing: bool = True) -> None:
        super().__init__(config, message_passing)
        hidden = config.hidden_channels
        self.orientation_head = nn.Linear(hidden, NUM_ORIENTATIONS)
        self.rack_head = nn.Sequential(
            nn.Linear(3 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, 1)
        )
        self.none_head = nn.Sequential(
            nn.Linear(3 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, 1)
        )

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
        pooled = torch.cat([mean, peak], dim=-1)
        # The rack nodes, found by their one-hot category columns (zero on padding).
        top = (x[..., RACK_TOP_COLUMN].unsqueeze(-1) * hidden).sum(dim=1)
        bottom = (x[..., RACK_BOTTOM_COLUMN].unsqueeze(-1) * hidden).sum(dim=1)
        tray = torch.cat(
            [
                self.rack_head(torch.cat([top, pooled], dim=-1)),
                self.rack_head(torch.cat([bottom, pooled], dim=-1)),
                self._place_score(x, hidden, pooled),
            ],
            dim=-1,
        )
        heads = DishHeads(self.head(hidden).squeeze(-1), self.orientation_head(hidden), tray)
        if single:
            return DishHeads(*(h.squeeze(0) for h in heads))
        return heads

    def _place_score(self, x: Tensor, hidden: Tensor, pooled: Tensor) -> Tensor:
        """The "none" (PickAndPlace) score: the best dish's, each dish scored at its node."""
        context = pooled.unsqueeze(1).expand(-1, hidden.shape[1], -1)
        scores = self.none_head(torch.cat([hidden, context], dim=-1)).squeeze(-1)
        is_dish = x[..., DISH_COLUMNS].sum(dim=-1) > 0
        best = scores.masked_fill(~is_dish, float("-inf")).amax(dim=1, keepdim=True)
        return torch.where(torch.isfinite(best), best, torch.zeros_like(best))
