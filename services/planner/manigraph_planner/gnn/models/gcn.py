r"""The paper's "GCN" policy layers (Morris et al., 2019, "Weisfeiler and Leman go neural").

.. math::
    h_i^l = \mathrm{ReLU}\Big(\theta_1 h_i^{l-1}
        + \theta_2 \sum_{j \in \mathcal{N}(i)} e_{j,i} \cdot h_j^{l-1}\Big)

This is exactly PyG's :class:`~torch_geometric.nn.conv.GraphConv` with ``aggr="add"``
(``lin_root`` is :math:`\theta_1`, ``lin_rel`` is :math:`\theta_2`); not PyG's ``GCNConv``,
which normalises by node degree and has no separate root weight. The graph state carries no
edge weights, so :math:`e_{j,i} = 1`. On a complete graph the sum runs over every other node.
"""

from __future__ import annotations

from typing import Any

from torch import Tensor, nn

from manigraph_planner.gnn.models.backbone import ConvStack, register_architecture
from manigraph_planner.gnn.models.complete_graph import neighbour_sum
from manigraph_planner.gnn.models.layer_weights import GraphConvWeights


@register_architecture("gcn")
class GCNBackbone(ConvStack):
    """Stacked ``GraphConv(aggr="add")`` layers with ReLU."""

    def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
        from torch_geometric.nn import GraphConv

        return GraphConv(in_channels, out_channels, aggr="add")

    def make_weights(self, in_channels: int, out_channels: int) -> nn.Module:
        return GraphConvWeights(in_channels, out_channels)

    def conv_complete(self, conv: Any, x: Tensor, mask: Tensor | None = None) -> Tensor:
        return conv.lin_rel(neighbour_sum(x, mask)) + conv.lin_root(x)
