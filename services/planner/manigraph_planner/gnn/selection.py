r"""From node logits to the paper's two categorical distributions, its loss and its choice.

For each graph :math:`b` of a batch, the node logits are split into the object logits
:math:`v^o` and goal logits :math:`v^g`, each normalised on its own:

.. math::
    p(o_k) = \frac{\exp v^o_k}{\sum_{k'=1}^{K} \exp v^o_{k'}}, \qquad
    p(g_l) = \frac{\exp v^g_l}{\sum_{l'=1}^{L} \exp v^g_{l'}}

With one-hot expert targets, the cross entropy of the paper's Eq. (ce) reduces to

.. math::
    \mathcal{L} = \frac{1}{B} \sum_{b=1}^{B}
        \big[-\log p(o^\text{exp}_b) - \log p(g^\text{exp}_b)\big]

Graphs may have different sizes; everything runs as scatter operations over the batch vector.
A *group* is (graph, objects) or (graph, goals): node :math:`i` is in group
:math:`2\,\mathrm{batch}_i + [i \text{ is a goal}]`.
"""

from __future__ import annotations

import torch
from torch import Tensor
from torch_geometric.utils import scatter

__all__ = ["select", "selection_loss", "split_logits"]


def _groups(is_object: Tensor, batch: Tensor | None, num_graphs: int | None) -> tuple[Tensor, int]:
    if batch is None:
        batch = torch.zeros_like(is_object, dtype=torch.long)
    if num_graphs is None:
        num_graphs = int(batch.max()) + 1 if batch.numel() else 0
    return 2 * batch + (~is_object).long(), 2 * num_graphs


def split_logits(
    node_logits: Tensor,
    is_object: Tensor,
    batch: Tensor | None = None,
    num_graphs: int | None = None,
) -> Tensor:
    """Per-node log-probability: log-softmax over the objects, and separately over the
    goals, of the node's own graph.

    Args:
        node_logits: one logit per node, from :class:`~manigraph_planner.gnn.models.PolicyNet`.
        is_object: True for object nodes, False for goal nodes.
        batch: graph of each node (PyG batch vector); None means one graph.
        num_graphs: number of graphs, if known (saves a device sync).

    Shapes:
        - **node_logits, is_object, batch:** :math:`(N,)`
        - **output:** :math:`(N,)`; ``output[is_object & (batch == b)].exp().sum() == 1``
    """
    group, num_groups = _groups(is_object, batch, num_graphs)
    peak = scatter(node_logits.detach(), group, 0, num_groups, reduce="max")
    shifted = node_logits - peak[group]
    log_norm = scatter(shifted.exp(), group, 0, num_groups, reduce="sum").log()
    return shifted - log_norm[group]


def selection_loss(
    node_logits: Tensor,
    is_object: Tensor,
    batch: Tensor | None,
    object_target: Tensor,
    goal_target: Tensor,
) -> Tensor:
    """The paper's Eq. (ce) with one-hot targets, averaged over the graphs of a batch.

    Args:
        node_logits, is_object, batch: as in :func:`split_logits`.
        object_target: node index (into the batched node dimension) of the expert's object
            in each graph. In a PyG ``Batch``, store it as an attribute whose name contains
            ``index`` (e.g. ``object_index``) and PyG offsets it per graph for you.
        goal_target: node index of the expert's goal in each graph.

    Shapes:
        - **object_target, goal_target:** :math:`(B,)` int64
        - **output:** scalar

    Raises:
        ValueError: a target is not an object (goal) node.
    """
    if not bool(is_object[object_target].all()):
        raise ValueError("object_target: every target must index an object node")
    if bool(is_object[goal_target].any()):
        raise ValueError("goal_target: every target must index a goal node")
    log_prob = split_logits(node_logits, is_object, batch, num_graphs=object_target.numel())
    return -(log_prob[object_target] + log_prob[goal_target]).mean()


def select(
    node_logits: Tensor,
    is_object: Tensor,
    batch: Tensor | None = None,
    num_graphs: int | None = None,
) -> tuple[Tensor, Tensor]:
    """Each graph's argmax object node and argmax goal node; ties go to the lower index.

    Args:
        node_logits, is_object, batch, num_graphs: as in :func:`split_logits`.

    Shapes:
        - **output:** ``(object_index, goal_index)``, each :math:`(B,)` int64 node indices
          into the batched node dimension; -1 where a graph has no object (goal) nodes.
    """
    group, num_groups = _groups(is_object, batch, num_graphs)
    peak = scatter(node_logits, group, 0, num_groups, reduce="max")
    nodes = torch.arange(node_logits.numel(), device=node_logits.device)
    sentinel = node_logits.numel()
    candidate = torch.where(node_logits == peak[group], nodes, sentinel)
    first = torch.full((num_groups,), sentinel, dtype=torch.long, device=node_logits.device)
    first = first.scatter_reduce(0, group, candidate, reduce="amin")
    first = torch.where(first == sentinel, -1, first)
    return first[0::2], first[1::2]
