r"""A policy network's node logits with every message scaled by an edge mask, as dense algebra.

The explainer scales the message along each edge :math:`j \to i` by a mask value
:math:`M_{ij}` and fits the masks by gradient. PyG does this with its explain hooks
(``set_masks``): each ``MessagePassing`` layer multiplies its messages by the mask before it
aggregates them. The four policy architectures are small dense formulas on a graph of
:math:`N \le 128` nodes, so the same function is written here with an :math:`N \times N` mask
matrix, reading the layers' parameters by PyG's names. That works on the planner's own
weights-only network (:mod:`~manigraph_planner.gnn.models.layer_weights`), so the explainer
needs no PyG import: it is ready as soon as the planner is (PyG's import took 13 s at load 2).

With :math:`A` the edge structure (1 where :math:`j \to i` is an edge) and :math:`M` the mask
(0 off the edges), one layer of each architecture is exactly what PyG computes under
``set_masks``:

- ``gcn`` (``GraphConv``, add): :math:`\theta_{rel} (M h) + \theta_{root} h`
- ``sage`` (``SAGEConv``, mean): :math:`\theta_l (M h / \deg_A) + \theta_r h` (PyG's mean
  divides by the number of edges, whatever their mask)
- ``gated`` (``GatedGraphConv``): :math:`h \leftarrow \mathrm{GRU}(M (h W_l), h)`
- ``gat`` (``GATConv``, one head): :math:`(M \odot \alpha)\, \theta h + \theta_{res} h + b`,
  :math:`\alpha` the attention softmax over :math:`A`'s edges (the mask scales the message
  :math:`\alpha_{ij} \theta h_j` after the softmax, as PyG's hook does)

Any other architecture (one registered later) falls back to PyG's hooks on the network's
message-passing twin (:func:`~manigraph_planner.gnn.models.build.with_message_passing`).
"""

from __future__ import annotations

import copy
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor

from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.models.gat import GATBackbone
from manigraph_planner.gnn.models.gated import GatedBackbone
from manigraph_planner.gnn.models.gcn import GCNBackbone
from manigraph_planner.gnn.models.sage import SAGEBackbone

__all__ = ["MaskedNet"]

_DENSE = (GCNBackbone, SAGEBackbone, GatedBackbone, GATBackbone)


class MaskedNet:
    """A frozen private copy of a policy network, called with an edge mask.

    Args:
        net: a :class:`PolicyNet` (weights-only or PyG); copied, so the served policy is never
            touched.
    """

    def __init__(self, net: PolicyNet) -> None:
        self.dense = type(net) is PolicyNet and isinstance(net.backbone, _DENSE)
        if not self.dense:
            from manigraph_planner.gnn.models.build import with_message_passing

            net = with_message_passing(net)
        self.net = copy.deepcopy(net).eval()
        self.net.requires_grad_(False)

    def __call__(self, x: Tensor, edge_index: Tensor, edge_mask: Tensor | None) -> Tensor:
        """Node logits of the graph ``(x, edge_index)`` with each edge's message multiplied by
        ``edge_mask`` (None: unmasked).

        Shapes:
            - **x:** :math:`(N, F)`; **edge_index:** :math:`(2, E)`; **edge_mask:** :math:`(E,)`
            - **output:** :math:`(N,)`
        """
        if not self.dense:
            return self._message_passing(x, edge_index, edge_mask)
        num_nodes = x.shape[0]
        target, source = edge_index[1], edge_index[0]
        structure = x.new_zeros(num_nodes, num_nodes).index_put(
            (target, source), x.new_ones(edge_index.shape[1]), accumulate=True
        )
        weights = (
            structure
            if edge_mask is None
            else x.new_zeros(num_nodes, num_nodes).index_put(
                (target, source), edge_mask.to(x.dtype), accumulate=True
            )
        )
        hidden = _backbone(self.net.backbone, x * self.net.feature_scale, structure, weights)
        return self.net.head(hidden).squeeze(-1)

    @property
    def decodes_pairs(self) -> bool:
        """The network has a ``pairs`` decoder (:mod:`~manigraph_planner.gnn.pair_decoder`)."""
        return self.net.decodes_pairs

    def pair_logits(self, x: Tensor) -> Tensor:
        """A ``pairs`` decoder's pair logits of node features ``x`` :math:`(N, F)`: they read
        the features only, so feature masks reach them and edge masks do not."""
        return self.net.pair_logits(x)

    def _message_passing(self, x: Tensor, edge_index: Tensor, edge_mask: Tensor | None) -> Tensor:
        if edge_mask is None:
            return self.net(x, edge_index)
        from torch_geometric.explain.algorithm.utils import clear_masks, set_masks

        set_masks(self.net, edge_mask, edge_index, apply_sigmoid=False)
        try:
            return self.net(x, edge_index)
        finally:
            clear_masks(self.net)


def _backbone(backbone: Any, h: Tensor, structure: Tensor, weights: Tensor) -> Tensor:
    """Hidden states: ``structure`` :math:`A` and ``weights`` :math:`M`, both ``[i, j]`` for
    the edge :math:`j \\to i`."""
    if isinstance(backbone, GatedBackbone):
        gated: Any = backbone.conv
        h = F.pad(h, (0, backbone.hidden_channels - h.shape[-1]))
        for weight in gated.weight:
            h = gated.rnn(weights @ (h @ weight), h)
        return h.relu()
    assert isinstance(backbone, GCNBackbone | SAGEBackbone | GATBackbone)
    layer: Any
    for layer in backbone.convs:
        if isinstance(backbone, GCNBackbone):
            h = layer.lin_rel(weights @ h) + layer.lin_root(h)
        elif isinstance(backbone, SAGEBackbone):
            degree = structure.sum(dim=1, keepdim=True).clamp(min=1)
            h = layer.lin_l((weights @ h) / degree) + layer.lin_r(h)
        else:
            h = _attend(layer, h, structure, weights)
        h = h.relu()
    return h


def _attend(gat: Any, h: Tensor, structure: Tensor, weights: Tensor) -> Tensor:
    projected = gat.lin(h)
    score_src = projected @ gat.att_src.view(-1)
    score_dst = projected @ gat.att_dst.view(-1)
    scores = F.leaky_relu(score_dst.unsqueeze(1) + score_src.unsqueeze(0), gat.negative_slope)
    edges = structure > 0
    lowest = torch.finfo(scores.dtype).min
    alpha = scores.masked_fill(~edges, lowest).softmax(dim=1).masked_fill(~edges, 0)
    return (weights * alpha) @ projected + gat.res(h) + gat.bias
