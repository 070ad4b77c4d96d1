r"""The paper's "Gated" policy layers (Li et al., 2016, gated graph sequence networks).

.. math::
    h_i^0 = [\,\phi(v_i) \,\Vert\, \mathbf{0}\,], \qquad
    h_i^l = \mathrm{GRU}\Big(h_i^{l-1},\; \sum_{j \in \mathcal{N}(i)} \theta_1^l h_j^{l-1}\Big),
    \qquad \text{output } \mathrm{ReLU}(h_i^L)

PyG's :class:`~torch_geometric.nn.conv.GatedGraphConv` with ``num_layers`` propagation steps:
each step has its own :math:`\theta_1^l`, the GRU cell is shared across steps (as in the
original GGNN). Input features are zero-padded to ``hidden_channels`` (``GatedGraphConv``
needs ``in_channels <= hidden_channels``), so no learned input projection is added. One ReLU
follows the last step, matching the other architectures' "ReLU hidden layers".
PyG multiplies before aggregating (:math:`\theta_1^l h_j`, weight ``conv.weight[l]`` applied as
``h @ weight[l]``) and calls the GRU cell as ``rnn(m, h)``; the dense path does the same.
"""

from __future__ import annotations

from typing import Any

import torch.nn.functional as F
from torch import Tensor

from manigraph_planner.gnn.models.backbone import Backbone, register_architecture
from manigraph_planner.gnn.models.complete_graph import neighbour_sum
from manigraph_planner.gnn.models.layer_weights import GatedWeights
from manigraph_shared.errors import ConfigError


@register_architecture("gated")
class GatedBackbone(Backbone):
    """One ``GatedGraphConv(hidden_channels, num_layers)`` followed by ReLU."""

    def __init__(
        self, in_channels: int, hidden_channels: int, num_layers: int, message_passing: bool = True
    ) -> None:
        super().__init__(in_channels, hidden_channels, num_layers, message_passing)
        if hidden_channels < in_channels:
            raise ConfigError(
                "hidden_channels",
                f"the gated architecture needs at least in_channels={in_channels}, "
                f"got {hidden_channels}",
            )
        if message_passing:
            from torch_geometric.nn import GatedGraphConv

            self.conv: Any = GatedGraphConv(hidden_channels, num_layers, aggr="add")
        else:
            self.conv = GatedWeights(hidden_channels, num_layers)

    def forward(self, x: Tensor, edge_index: Tensor) -> Tensor:
        return self.conv(x, edge_index).relu()

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        h = F.pad(x, (0, self.hidden_channels - x.shape[-1]))  # [phi || 0], as PyG pads
        for weight in self.conv.weight:
            message = neighbour_sum(h @ weight, mask)
            # The GRU cell takes (nodes, channels); a padded batch's graphs are flattened.
            flat = self.conv.rnn(message.reshape(-1, h.shape[-1]), h.reshape(-1, h.shape[-1]))
            h = flat.view_as(h)
        return h.relu()
