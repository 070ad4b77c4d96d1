r"""The ``pairs`` decoder: the object, then the goal given the object.

The paper's decoder (:mod:`~manigraph_planner.gnn.selection`) normalises objects and goals
apart, so the object head cannot know which goal the goal head picks. Here the object head
is the paper's, and the goal is chosen given the object from pair logits :math:`s(o, g)`
(:class:`~manigraph_planner.gnn.models.pair_head.PairHead`):

.. math::
    p(o, g) = p(o)\, p(g \mid o), \qquad
    p(g \mid o) = \frac{\exp s(o, g)}{\sum_{g' \in C(o)} \exp s(o, g')}, \qquad
    \mathcal{L} = -\frac{1}{B} \sum_b \big[\log p(o^\text{exp}_b)
        + \log p(g^\text{exp}_b \mid o^\text{exp}_b)\big]

with :math:`p(o)` the softmax over the object nodes' logits and :math:`C(o)` the goals whose
category fits :math:`o` (a block into a block goal, a cover onto a cover goal: the paper's
codes, object :math:`c` fills goal :math:`3 - c`). The decision is the pair of highest
:math:`\log p(o) + \log p(g \mid o)`, ties to the first in row-major (object, then goal)
order. Why conditional, not one softmax over all pairs: a teacher's object order that the
scene does not show (ids) is noise to :math:`p(o)`, but :math:`p(g \mid o)` is the same
function for every object, so "a red block goes to a red bin" is learned from each
demonstrated pair and applies to the blocks the teacher did not pick (docs/training.md).
"""

from __future__ import annotations

import torch
from torch import Tensor

from manigraph_planner.gnn.selection import padded_split_logits

__all__ = [
    "best_pair",
    "category_compatible",
    "joint_log_probs",
    "padded_pair_loss",
    "padded_pair_select",
    "padded_valid_pairs",
    "ranked_pairs",
]


def category_compatible(object_codes: Tensor, goal_codes: Tensor) -> Tensor:
    """``[..., o, g]``: object ``o``'s category fits goal ``g``'s (paper codes: cover 0
    fills cover-goal 3, block 1 fills block-goal 2). Shapes: :math:`(..., K)`,
    :math:`(..., L)` -> :math:`(..., K, L)`."""
    return (3 - object_codes.round()).unsqueeze(-1) == goal_codes.round().unsqueeze(-2)


def padded_valid_pairs(x: Tensor, is_object: Tensor, mask: Tensor) -> Tensor:
    """Which node pairs of a padded batch are a real object and a compatible real goal.

    Shapes:
        - **x:** :math:`(B, N, F)` (column 0 the category code); **is_object, mask:**
          :math:`(B, N)`
        - **output:** :math:`(B, N, N)` bool, ``[b, o, g]``
    """
    objects, goals = is_object & mask, ~is_object & mask
    codes = x[..., 0]
    return objects.unsqueeze(-1) & goals.unsqueeze(-2) & category_compatible(codes, codes)


def joint_log_probs(object_logp: Tensor, pair_logits: Tensor, valid: Tensor) -> Tensor:
    """:math:`\\log p(o) + \\log p(g \\mid o)` for every valid pair; the lowest finite float
    elsewhere (no NaN gradients where a row has no valid goal).

    Shapes:
        - **object_logp:** :math:`(..., K)` :math:`\\log p(o)` of the row nodes;
          **pair_logits, valid:** :math:`(..., K, L)`
        - **output:** :math:`(..., K, L)`
    """
    lowest = torch.finfo(pair_logits.dtype).min
    given = pair_logits.masked_fill(~valid, lowest).log_softmax(dim=-1)
    joint = object_logp.unsqueeze(-1) + given
    return joint.masked_fill(~valid, lowest)


def padded_pair_loss(
    node_logits: Tensor,
    pair_logits: Tensor,
    is_object: Tensor,
    mask: Tensor,
    valid: Tensor,
    object_target: Tensor,
    goal_target: Tensor,
) -> Tensor:
    """:math:`-\\log p(o^*) - \\log p(g^* \\mid o^*)`, averaged over the graphs of a padded
    batch.

    Shapes:
        - **node_logits, is_object, mask:** :math:`(B, N)`; **pair_logits, valid:**
          :math:`(B, N, N)`; **object_target, goal_target:** :math:`(B,)` int64 node
          indices within each graph
        - **output:** scalar

    Raises:
        ValueError: a target pair is not a valid (object, compatible goal) pair.
    """
    graphs = torch.arange(pair_logits.shape[0], device=pair_logits.device)
    if not bool(valid[graphs, object_target, goal_target].all()):
        raise ValueError("pair target: every expert pair must be an object and a compatible goal")
    object_logp = padded_split_logits(node_logits, is_object, mask)
    joint = joint_log_probs(object_logp, pair_logits, valid)
    return -joint[graphs, object_target, goal_target].mean()


def padded_pair_select(
    node_logits: Tensor, pair_logits: Tensor, is_object: Tensor, mask: Tensor, valid: Tensor
) -> tuple[Tensor, Tensor]:
    """Each graph's most likely valid pair as ``(object_index, goal_index)`` node indices
    within the graph, each :math:`(B,)`; -1 where a graph has no valid pair."""
    object_logp = padded_split_logits(node_logits, is_object, mask)
    joint = joint_log_probs(object_logp, pair_logits, valid)
    flat = joint.masked_fill(~valid, float("-inf")).flatten(1)
    best = flat.argmax(dim=-1)  # the first maximum: row-major order
    width = pair_logits.shape[-1]
    found = valid.flatten(1).any(dim=-1)
    return torch.where(found, best // width, -1), torch.where(found, best % width, -1)


def best_pair(scores: Tensor, valid: Tensor) -> tuple[int, int] | None:
    """The first maximal valid ``(o, g)`` of ``scores`` :math:`(K, L)`; None without one."""
    if not bool(valid.any()):
        return None
    flat = int(scores.masked_fill(~valid, float("-inf")).flatten().argmax())
    return flat // scores.shape[1], flat % scores.shape[1]


def ranked_pairs(scores: Tensor, valid: Tensor) -> list[tuple[int, int]]:
    """Every valid ``(o, g)`` by ``scores`` :math:`(K, L)`, highest first; equal scores in
    row-major order, so the first is :func:`best_pair`'s."""
    order = torch.sort(scores.flatten(), descending=True, stable=True).indices
    width = scores.shape[1]
    flat = valid.flatten()
    return [(int(i) // width, int(i) % width) for i in order if bool(flat[i])]
