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

Graphs may have different sizes. A PyG batch concatenates them and everything runs as
scatter operations over the batch vector: a *group* is (graph, objects) or (graph, goals),
node :math:`i` is in group :math:`2\,\mathrm{batch}_i + [i \text{ is a goal}]`. A *padded*
batch (:meth:`~manigraph_planner.gnn.models.PolicyNet.forward_complete`) stacks them as
:math:`(B, N_{max})` with a node mask, and the ``padded_*`` functions compute the same as
row-wise masked reductions, with node indices counted within each graph.
"""

from __future__ import annotations

import torch
from torch import Tensor

__all__ = [
    "padded_select",
    "padded_selection_loss",
    "padded_split_logits",
    "select",
    "selection_loss",
    "split_logits",
]


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
    peak = _group_max(node_logits.detach(), group, num_groups)
    shifted = node_logits - peak[group]
    log_norm = _group_sum(shifted.exp(), group, num_groups).log()
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
    _check_targets(is_object[object_target], ~is_object[goal_target])
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
    peak = _group_max(node_logits, group, num_groups)
    nodes = torch.arange(node_logits.numel(), device=node_logits.device)
    sentinel = node_logits.numel()
    candidate = torch.where(node_logits == peak[group], nodes, sentinel)
    first = torch.full((num_groups,), sentinel, dtype=torch.long, device=node_logits.device)
    first = first.scatter_reduce(0, group, candidate, reduce="amin")
    first = torch.where(first == sentinel, -1, first)
    return first[0::2], first[1::2]


def padded_split_logits(node_logits: Tensor, is_object: Tensor, mask: Tensor) -> Tensor:
    """:func:`split_logits` of a padded batch: per-node log-probability within the objects,
    and separately the goals, of the node's own graph.

    Args:
        node_logits: one logit per node slot; padded slots may hold anything finite.
        is_object: True for object nodes, False for goal nodes (and padding).
        mask: True for real nodes, False for padding.

    Shapes:
        - **node_logits, is_object, mask:** :math:`(B, N_{max})`
        - **output:** :math:`(B, N_{max})`; -inf at padding
    """
    objects, goals = is_object & mask, ~is_object & mask
    # The smallest finite logit, not -inf, outside a group: a graph without goals (objects)
    # then gives finite values, later discarded, rather than NaN in the gradients.
    lowest = torch.finfo(node_logits.dtype).min
    object_log_prob = node_logits.masked_fill(~objects, lowest).log_softmax(dim=-1)
    goal_log_prob = node_logits.masked_fill(~goals, lowest).log_softmax(dim=-1)
    log_prob = torch.where(objects, object_log_prob, goal_log_prob)
    return log_prob.masked_fill(~mask, float("-inf"))


def padded_selection_loss(
    node_logits: Tensor,
    is_object: Tensor,
    mask: Tensor,
    object_target: Tensor,
    goal_target: Tensor,
) -> Tensor:
    """:func:`selection_loss` of a padded batch: the paper's Eq. (ce), averaged over graphs.

    Args:
        node_logits, is_object, mask: as in :func:`padded_split_logits`.
        object_target: node index of the expert's object within each graph.
        goal_target: node index of the expert's goal within each graph.

    Shapes:
        - **object_target, goal_target:** :math:`(B,)` int64
        - **output:** scalar

    Raises:
        ValueError: a target is not a real object (goal) node.
    """
    graphs = torch.arange(node_logits.shape[0], device=node_logits.device)
    real_objects, real_goals = is_object & mask, ~is_object & mask
    _check_targets(real_objects[graphs, object_target], real_goals[graphs, goal_target])
    log_prob = padded_split_logits(node_logits, is_object, mask)
    return -(log_prob[graphs, object_target] + log_prob[graphs, goal_target]).mean()


def padded_select(node_logits: Tensor, is_object: Tensor, mask: Tensor) -> tuple[Tensor, Tensor]:
    """:func:`select` of a padded batch: each graph's argmax object and argmax goal node;
    ties go to the lower index.

    Args:
        node_logits, is_object, mask: as in :func:`padded_split_logits`.

    Shapes:
        - **output:** ``(object_index, goal_index)``, each :math:`(B,)` int64 node indices
          within each graph; -1 where a graph has no object (goal) nodes.
    """
    chosen = []
    for group in (is_object & mask, ~is_object & mask):
        best = node_logits.masked_fill(~group, float("-inf")).argmax(dim=-1)  # first maximum
        chosen.append(torch.where(group.any(dim=-1), best, -1))
    return chosen[0], chosen[1]


def _check_targets(object_is_object: Tensor, goal_is_goal: Tensor) -> None:
    if not bool(object_is_object.all()):
        raise ValueError("object_target: every target must index an object node")
    if not bool(goal_is_goal.all()):
        raise ValueError("goal_target: every target must index a goal node")


# What ``torch_geometric.utils.scatter`` computes for "max" and "sum" over dimension 0, by the
# same torch calls, so that selection (used by policy serving) does not import PyG.
def _group_max(values: Tensor, group: Tensor, num_groups: int) -> Tensor:
    """Per-group maximum of ``values``; 0 for a group without members."""
    out = values.new_zeros(num_groups)
    return out.scatter_reduce(0, group, values, reduce="amax", include_self=False)


def _group_sum(values: Tensor, group: Tensor, num_groups: int) -> Tensor:
    """Per-group sum of ``values`` (differentiable)."""
    return values.new_zeros(num_groups).scatter_add(0, group, values)
