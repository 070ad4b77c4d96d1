r"""Neighbourhood reductions on complete graphs without self loops, as dense algebra.

Every graph state in manigraph is complete: node :math:`i` receives from every
:math:`j \neq i` (see :func:`~manigraph_planner.gnn.features.fully_connected_edge_index`).
There a sum over the neighbours is the sum over all nodes minus the node itself,

.. math::
    \sum_{j \neq i} m_j = \Big(\sum_j m_j\Big) - m_i,

so a layer needs neither an edge index nor the :math:`N (N - 1)` per-edge tensors PyG's
message passing gathers and scatters. Backbones use these helpers in
:meth:`~manigraph_planner.gnn.models.Backbone.forward_complete`; results equal PyG's up to
float rounding (the summation order differs).

Each helper takes one graph, :math:`(N, F)`, or a *padded batch*: :math:`B` graphs of
different sizes stacked as :math:`(B, N_{max}, F)` with a node ``mask`` :math:`(B, N_{max})`,
True for real nodes. A padded node is nobody's neighbour; what the helpers return at padded
nodes is finite but unspecified, so callers ignore it (e.g. the loss masks those logits).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_planner.gnn.features import fully_connected_edge_index

__all__ = [
    "AttentionStructure",
    "complete_edge_index",
    "message_passing_on_complete",
    "neighbour_mean",
    "neighbour_softmax",
    "neighbour_sum",
]


def neighbour_sum(x: Tensor, mask: Tensor | None = None) -> Tensor:
    r""":math:`\sum_{j \neq i} x_j` over the real nodes :math:`j` of node :math:`i`'s graph
    (PyG ``aggr="add"``).

    Shapes:
        - **x:** :math:`(N, F)`, or :math:`(B, N_{max}, F)` with **mask** :math:`(B, N_{max})`
        - **output:** like ``x``; zeros for a graph of one node
    """
    if mask is not None:
        x = x.masked_fill(~mask.unsqueeze(-1), 0)  # not a product: keeps padding out of grads
    return x.sum(dim=-2, keepdim=True) - x


def neighbour_mean(x: Tensor, mask: Tensor | None = None) -> Tensor:
    r""":math:`\frac{1}{N - 1} \sum_{j \neq i} x_j`, :math:`N` the size of node :math:`i`'s
    graph (PyG ``aggr="mean"``; zeros, as in PyG, for a lone node without neighbours).

    Shapes:
        - **x:** :math:`(N, F)`, or :math:`(B, N_{max}, F)` with **mask** :math:`(B, N_{max})`
        - **output:** like ``x``
    """
    if mask is None:
        return neighbour_sum(x) / max(x.shape[-2] - 1, 1)
    neighbours = mask.sum(dim=-1, keepdim=True).unsqueeze(-1) - 1  # (B, 1, 1)
    return neighbour_sum(x, mask) / neighbours.clamp(min=1)


def neighbour_softmax(scores: Tensor, mask: Tensor | None = None) -> Tensor:
    r"""Row-wise softmax over the neighbours: entry :math:`(i, j)` is
    :math:`\exp(s_{ij}) / \sum_{k \neq i} \exp(s_{ik})` for real nodes :math:`j \neq i`, else 0
    (PyG's :func:`~torch_geometric.utils.softmax` over the edges into :math:`i`).

    Shapes:
        - **scores:** :math:`(N, N)`, or :math:`(B, N_{max}, N_{max})` with **mask**
          :math:`(B, N_{max})`; row :math:`i` the target, column :math:`j` the source
        - **output:** like ``scores``; all-zero rows where a node has no neighbours
    """
    edges = _neighbours(scores.shape[-1], mask, scores.device)
    # The smallest finite score, not -inf: a row without neighbours then stays finite (and is
    # zeroed below) instead of becoming NaN, which would also poison the gradients.
    lowest = torch.finfo(scores.dtype).min
    return scores.masked_fill(~edges, lowest).softmax(dim=-1).masked_fill(~edges, 0)


@dataclass(frozen=True)
class AttentionStructure:
    r"""Which score of an :math:`N \times N` attention matrix is an edge, for every attention
    layer of one forward pass: built once per pass (not once per layer), as additive offsets
    rather than boolean masks, so that a layer spends no pass over its :math:`B N^2` scores
    on masking them.

    :meth:`scores` adds a quarter of the dtype's lowest value (three of them still sum to a
    finite number) to every score that is not an edge: on the diagonal and wherever
    the source or the target is padding. A layer may then apply any increasing activation
    with :math:`f(0) = 0` (LeakyReLU) and :meth:`softmax` the result. Wherever a row has an
    edge, the edges keep exactly their scores (:math:`s + 0 = s`) and every other entry gets
    weight exactly 0 (:math:`\exp` of a number below :math:`-10^{37}`), with gradient exactly
    0, as :func:`neighbour_softmax` gives after its masks: the same numbers, without
    allocating and filling two masked copies per layer and their gradients.
    Rows without an edge are all-zero for a real lone node, as in :func:`neighbour_softmax`,
    and finite but unspecified at padding, whose outputs nobody reads.

    Shapes: for a padded batch ``node_offset`` :math:`(B, N)` (0 at real nodes) and ``lone``
    :math:`(B, N, 1)` or None; for one graph both None. ``self_offset`` :math:`(N, N)`.
    """

    self_offset: Tensor
    node_offset: Tensor | None
    #: 0.0 at a real node without neighbours, 1.0 elsewhere; None where there is no such node.
    lone: Tensor | None

    @classmethod
    def of(cls, x: Tensor, mask: Tensor | None = None) -> AttentionStructure:
        """The structure of ``x`` (:math:`(N, F)`, or :math:`(B, N_{max}, F)` with ``mask``)."""
        num_nodes, far = x.shape[-2], _far(x.dtype)
        eye = torch.eye(num_nodes, dtype=x.dtype, device=x.device)
        self_offset = eye * far
        if mask is None:
            return cls(self_offset, None, torch.zeros_like(eye) if num_nodes == 1 else None)
        node_offset = torch.zeros(mask.shape, dtype=x.dtype, device=x.device)
        node_offset.masked_fill_(~mask, far)
        sizes = mask.sum(dim=-1, keepdim=True)
        lone = None
        if bool((sizes == 1).any()):  # graphs of one node: rarely; the only rows to zero
            lone = ~(mask & (sizes == 1))
            lone = lone.to(x.dtype).unsqueeze(-1)
        return cls(self_offset, node_offset, lone)

    def scores(self, target: Tensor, source: Tensor) -> Tensor:
        r"""A fresh :math:`(\ldots, N, N)` tensor of ``target[i] + source[j]`` at edges
        :math:`j \to i`, and far below any score elsewhere.

        Shapes: ``target`` and ``source`` :math:`(N,)` or :math:`(B, N)`."""
        if self.node_offset is not None:
            target, source = target + self.node_offset, source + self.node_offset
        pairs = torch.add(target.unsqueeze(-1), source.unsqueeze(-2))
        return pairs.add_(self.self_offset)

    def softmax(self, scores: Tensor) -> Tensor:
        """Row-wise softmax of :meth:`scores` (through an activation): the weights over each
        node's neighbours, as :func:`neighbour_softmax` gives them."""
        weights = scores.softmax(dim=-1)
        return weights if self.lone is None else weights * self.lone


def _far(dtype: torch.dtype) -> float:
    return torch.finfo(dtype).min / 4


def complete_edge_index(mask: Tensor) -> Tensor:
    r"""Edge indices of a padded batch of complete graphs, over its flattened node dimension
    (node ``i`` of graph ``b`` is ``b * N_max + i``): every ordered pair of different real
    nodes of the same graph, each graph's sorted by source then target as in
    :func:`~manigraph_planner.gnn.features.fully_connected_edge_index`.

    Shapes:
        - **mask:** :math:`(B, N_{max})`
        - **output:** :math:`(2, \sum_b N_b (N_b - 1))` int64
    """
    graph, source, target = _neighbours(mask.shape[-1], mask, mask.device).nonzero().unbind(1)
    offset = graph * mask.shape[-1]
    return torch.stack([offset + source, offset + target])


def message_passing_on_complete(
    layer: Callable[[Tensor, Tensor], Tensor], x: Tensor, mask: Tensor | None = None
) -> Tensor:
    """``layer(x, edge_index)`` on one complete graph, or on a padded batch of them: the
    fallback for layers without dense algebra, which builds the per-edge tensors.

    Shapes:
        - **x:** :math:`(N, F)`, or :math:`(B, N_{max}, F)` with **mask** :math:`(B, N_{max})`
        - **output:** :math:`(N, F_{out})`, or :math:`(B, N_{max}, F_{out})`
    """
    if mask is None:
        return layer(x, fully_connected_edge_index(x.shape[0]))
    out = layer(x.reshape(-1, x.shape[-1]), complete_edge_index(mask))
    return out.view(*mask.shape, -1)


def _neighbours(num_nodes: int, mask: Tensor | None, device: torch.device) -> Tensor:
    """True at ``[..., i, j]`` where ``i != j`` are real nodes of one graph (symmetric).
    Shapes: :math:`(N, N)`, or :math:`(B, N_{max}, N_{max})` with a mask."""
    edges = ~torch.eye(num_nodes, dtype=torch.bool, device=device)
    if mask is None:
        return edges
    return edges & mask.unsqueeze(-1) & mask.unsqueeze(-2)
