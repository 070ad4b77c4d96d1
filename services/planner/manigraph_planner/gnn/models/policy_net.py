r"""A GNN policy network: registered message-passing backbone plus a one-logit node head.

.. math::
    h = \mathrm{backbone}(s \odot \phi,\; E), \qquad v_i = w^\top h_i + b

with :math:`s` the fixed ``feature_scale``. The :math:`N` node logits :math:`v` are read as
the paper's :math:`K + L` outputs: a softmax over the object nodes picks the object, a
softmax over the goal nodes picks the goal (see :mod:`manigraph_planner.gnn.selection`).
With ``decoder = "pairs"`` the object logits still give :math:`p(o)`, and a
:class:`~manigraph_planner.gnn.models.pair_head.PairHead` scores every (object, goal) pair
for :math:`p(g \mid o)` (:mod:`manigraph_planner.gnn.pair_decoder`).
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from manigraph_planner.gnn.models.backbone import ARCHITECTURES
from manigraph_planner.gnn.models.config import ModelConfig
from manigraph_planner.gnn.models.pair_head import PairHead

__all__ = ["PolicyNet"]


class PolicyNet(nn.Module):
    """Node-scoring network of a GNN policy.

    Args:
        config: architecture and sizes.
        message_passing: False builds only the layers' weights: :meth:`forward_complete`
            works, :meth:`forward` (message passing) does not, and PyG is never imported
            (see :mod:`~manigraph_planner.gnn.models.layer_weights`).

    Shapes:
        - **input:** node features :math:`(N, 5)`, edge indices :math:`(2, E)`,
          batch vector :math:`(N,)` (optional)
        - **output:** node logits :math:`(N,)`
    """

    def __init__(self, config: ModelConfig, message_passing: bool = True) -> None:
        super().__init__()
        self.config = config
        self.message_passing = message_passing
        backbone = ARCHITECTURES[config.architecture]
        self.backbone = backbone(
            config.input_size, config.hidden_channels, config.num_layers, message_passing
        )
        self.head = nn.Linear(config.hidden_channels, 1)
        # Only a pairs decoder has one: a nodes network's state_dict is what it always was.
        self.pair_head = PairHead(config.input_size) if config.decoder == "pairs" else None
        # Not persistent: ModelConfig is the source of truth and travels in the checkpoint.
        scale = torch.tensor(config.feature_scale, dtype=torch.float32)
        self.feature_scale: Tensor
        self.register_buffer("feature_scale", scale, persistent=False)

    @property
    def architecture(self) -> str:
        return self.config.architecture

    def forward(self, x: Tensor, edge_index: Tensor, batch: Tensor | None = None) -> Tensor:
        """Node logits. ``batch`` is accepted for symmetry with PyG models; graphs in a batch
        are disjoint, so message passing never needs it."""
        del batch
        hidden = self.backbone(x * self.feature_scale, edge_index)
        return self.head(hidden).squeeze(-1)

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        """Node logits of one graph state, i.e. ``forward(x, fully_connected_edge_index(N))``
        up to float rounding, by dense algebra without an edge index (see
        :meth:`~manigraph_planner.gnn.models.Backbone.forward_complete`); or of each graph
        state of a padded batch, as if run one by one. What policy inference (one graph) and
        training (padded batches) run; the explainer's edge masks need :meth:`forward`.

        Shapes:
            - **x:** node features :math:`(N, 5)`, or :math:`(B, N_{max}, 5)` with **mask**
              :math:`(B, N_{max})`, True for real nodes
            - **output:** node logits :math:`(N,)`, or :math:`(B, N_{max})`; finite but
              unspecified at padded nodes
        """
        hidden = self.backbone.forward_complete(x * self.feature_scale, mask)
        return self.head(hidden).squeeze(-1)

    @property
    def decodes_pairs(self) -> bool:
        return self.pair_head is not None

    def pair_logits(self, x: Tensor) -> Tensor:
        r"""Every node pair's score for :math:`p(g \mid o)` from the (unscaled) input features
        (a ``pairs`` decoder only).

        Shapes:
            - **x:** :math:`(N, F)` or :math:`(B, N, F)`
            - **output:** :math:`(N, N)` or :math:`(B, N, N)`, ``[o, g]``: node ``o`` as
              the object, node ``g`` as the goal
        """
        if self.pair_head is None:
            raise ValueError("decoder: this network decodes nodes, it has no pair head")
        return self.pair_head(x * self.feature_scale)

    def pairs_complete(self, x: Tensor, mask: Tensor | None = None) -> tuple[Tensor, Tensor]:
        """Node logits (:meth:`forward_complete`) and :meth:`pair_logits` of one complete
        graph, or of each graph of a padded batch (the pairs' shape has one more :math:`N`)."""
        return self.forward_complete(x, mask), self.pair_logits(x)
