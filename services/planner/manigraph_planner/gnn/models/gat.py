r"""The paper's "Attention" policy layers (Veličković et al., 2018, graph attention).

.. math::
    h_i^l = \mathrm{ReLU}\Big(\theta_1 h_i^{l-1}
        + \sum_{j \in \mathcal{N}(i)} a_{i,j}\, \theta_2 h_j^{l-1}\Big),
    \qquad a_{i,j} = \operatorname{softmax}_j\big(\mathrm{LeakyReLU}(
        \mathbf{a}^\top [\theta_2 h_i \,\Vert\, \theta_2 h_j])\big)

PyG's :class:`~torch_geometric.nn.conv.GATConv` with one head (the paper), no added self
loops and ``residual=True``: the residual projection is the separate root weight
:math:`\theta_1` of the formula, and attention is spread over the neighbours only.
"""

from __future__ import annotations

from torch import nn
from torch_geometric.nn import GATConv

from manigraph_planner.gnn.models.backbone import ConvStack, register_architecture


@register_architecture("gat")
class GATBackbone(ConvStack):
    """Stacked single-head ``GATConv`` layers with a root (residual) weight and ReLU."""

    def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
        return GATConv(in_channels, out_channels, heads=1, add_self_loops=False, residual=True)
