r"""Neighbourhood reductions on one complete graph without self loops, as dense algebra.

Every graph state in manigraph is complete: node :math:`i` receives from every
:math:`j \neq i` (see :func:`~manigraph_planner.gnn.features.fully_connected_edge_index`).
There a sum over the neighbours is the sum over all nodes minus the node itself,

.. math::
    \sum_{j \neq i} m_j = \Big(\sum_j m_j\Big) - m_i,

so a layer needs neither an edge index nor the :math:`N (N - 1)` per-edge tensors PyG's
message passing gathers and scatters. Backbones use these helpers in
:meth:`~manigraph_planner.gnn.models.Backbone.forward_complete`; results equal PyG's up to
float rounding (the summation order differs).
"""

from __future__ import annotations

import torch
from torch import Tensor

__all__ = ["neighbour_mean", "neighbour_softmax", "neighbour_sum"]


def neighbour_sum(x: Tensor) -> Tensor:
    r""":math:`\sum_{j \neq i} x_j` for every node :math:`i` (PyG ``aggr="add"``).

    Shapes:
        - **input:** :math:`(N, F)`
        - **output:** :math:`(N, F)`; zeros when :math:`N = 1`
    """
    return x.sum(dim=0, keepdim=True) - x


def neighbour_mean(x: Tensor) -> Tensor:
    r""":math:`\frac{1}{N - 1} \sum_{j \neq i} x_j` (PyG ``aggr="mean"``; zeros, as in PyG,
    for a lone node without neighbours).

    Shapes:
        - **input:** :math:`(N, F)`
        - **output:** :math:`(N, F)`
    """
    return neighbour_sum(x) / max(x.shape[0] - 1, 1)


def neighbour_softmax(scores: Tensor) -> Tensor:
    r"""Row-wise softmax over the neighbours: entry :math:`(i, j)` is
    :math:`\exp(s_{ij}) / \sum_{k \neq i} \exp(s_{ik})` for :math:`j \neq i`, 0 on the diagonal
    (PyG's :func:`~torch_geometric.utils.softmax` over the edges into :math:`i`).

    Shapes:
        - **input:** :math:`(N, N)` scores, row :math:`i` the target, column :math:`j` the source
        - **output:** :math:`(N, N)`; all zeros when :math:`N = 1` (no edges, no weights)
    """
    num_nodes = scores.shape[0]
    if num_nodes < 2:  # a row of only -inf would give NaN
        return torch.zeros_like(scores)
    self_loops = torch.eye(num_nodes, dtype=torch.bool, device=scores.device)
    return scores.masked_fill(self_loops, float("-inf")).softmax(dim=-1)
