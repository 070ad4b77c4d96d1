r"""The paper's "Sage" policy layers (Hamilton et al., 2017, GraphSAGE).

.. math::
    h_i^l = \mathrm{ReLU}\Big(\theta_1 h_i^{l-1}
        + \frac{\theta_2}{|\mathcal{N}(i)|} \sum_{j \in \mathcal{N}(i)} h_j^{l-1}\Big)

PyG's :class:`~torch_geometric.nn.conv.SAGEConv` with ``aggr="mean"`` and its root weight
(``lin_r`` is :math:`\theta_1`, ``lin_l`` is :math:`\theta_2`). On a complete graph
:math:`|\mathcal{N}(i)| = N - 1`.
"""

from __future__ import annotations

from typing import Any

from torch import Tensor, nn

from manigraph_planner.gnn.models.backbone import ConvStack, register_architecture
from manigraph_planner.gnn.models.complete_graph import neighbour_mean
from manigraph_planner.gnn.models.layer_weights import SAGEWeights


@register_architecture("sage")
class SAGEBackbone(ConvStack):
    """Stacked ``SAGEConv(aggr="mean")`` layers with ReLU."""

    def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
        from torch_geometric.nn import SAGEConv

        return SAGEConv(in_channels, out_channels, aggr="mean", root_weight=True)

    def make_weights(self, in_channels: int, out_channels: int) -> nn.Module:
        return SAGEWeights(in_channels, out_channels)

    def conv_complete(self, conv: Any, x: Tensor, mask: Tensor | None = None) -> Tensor:
        return conv.lin_l(neighbour_mean(x, mask)) + conv.lin_r(x)
