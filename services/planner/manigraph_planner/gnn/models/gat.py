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

from typing import Any

import torch.nn.functional as F
from torch import Tensor, nn

from manigraph_planner.gnn.models.backbone import ConvStack, register_architecture
from manigraph_planner.gnn.models.complete_graph import AttentionStructure
from manigraph_planner.gnn.models.layer_weights import GATWeights


@register_architecture("gat")
class GATBackbone(ConvStack):
    """Stacked single-head ``GATConv`` layers with a root (residual) weight and ReLU."""

    def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
        from torch_geometric.nn import GATConv

        return GATConv(in_channels, out_channels, heads=1, add_self_loops=False, residual=True)

    def make_weights(self, in_channels: int, out_channels: int) -> nn.Module:
        return GATWeights(in_channels, out_channels)

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        structure = AttentionStructure.of(x, mask)  # once for every layer
        for conv in self.convs:
            x = self.attend(conv, x, structure).relu()
        return x

    def conv_complete(self, conv: Any, x: Tensor, mask: Tensor | None = None) -> Tensor:
        return self.attend(conv, x, AttentionStructure.of(x, mask))

    @staticmethod
    def attend(gat: Any, x: Tensor, structure: AttentionStructure) -> Tensor:
        r"""The layer as an :math:`N \times N` attention matrix, one per graph of a padded
        batch. With one head, PyG's ``att_src`` and ``att_dst`` (shape :math:`(1, 1, C)`) are
        the two halves of :math:`\mathbf{a}`; the score of edge :math:`j \to i` is
        :math:`\mathbf{a}_{dst}^\top \theta_2 h_i + \mathbf{a}_{src}^\top \theta_2 h_j`, and
        ``res`` (:math:`\theta_1`) and ``bias`` are added after aggregation. The scores of
        non-edges are pushed far down before LeakyReLU, in place, and get weight 0
        (:class:`AttentionStructure`)."""
        projected = gat.lin(x)  # lin: theta_2, shared by sources and targets (no bias)
        score_src = projected @ gat.att_src.view(-1)
        score_dst = projected @ gat.att_dst.view(-1)
        scores = structure.scores(score_dst, score_src)  # [..., i, j]: edge j -> i
        scores = F.leaky_relu(scores, gat.negative_slope, inplace=True)
        out = structure.softmax(scores) @ projected + gat.res(x)
        return out + gat.bias
