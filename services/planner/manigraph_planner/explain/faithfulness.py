r"""Is an explanation faithful to the policy? PyG's fidelity, for a pair decision.

PyG (``torch_geometric.explain.metric.fidelity``, GraphFramEx, arXiv:2206.09677) scores a
*model* explanation by whether the prediction survives on the explanation alone and whether it
falls without it:

.. math::
    \mathrm{fid}_{+} = 1 - \frac{1}{N} \sum_i \mathbb{1}(\hat y_i^{G_{C \setminus S}} = \hat y_i),
    \qquad
    \mathrm{fid}_{-} = 1 - \frac{1}{N} \sum_i \mathbb{1}(\hat y_i^{G_S} = \hat y_i)

where :math:`G_S` is the graph with the explanation's masks applied (features multiplied by
the node/feature mask, messages by the edge mask) and :math:`G_{C \setminus S}` the graph with
the complementary masks :math:`1 - M`. Here the prediction :math:`\hat y` is the policy's
decision, the most likely compatible (object, goal) pair, and the masks are the explanation's
hard ones (its kept edges and features are 1, the rest 0). A high fid+ and a low fid- mean the
explanation holds what the decision rests on.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_planner.explain.masked_forward import MaskedNet
from manigraph_planner.explain.masks import MaskExplanation
from manigraph_planner.gnn.pair_decoder import best_pair, category_compatible, joint_log_probs
from manigraph_planner.policies.gnn import best_compatible_pair

__all__ = ["Faithfulness", "faithfulness"]


@dataclass(frozen=True)
class Faithfulness:
    """One explanation's share of the figures.

    Attributes:
        kept: the decision on :math:`G_S` is the policy's, with the explanation's soft masks
            as PyG applies them by default (no threshold); averaged, its complement is fid-.
        lost: the decision on :math:`G_{C \\setminus S}` (masks :math:`1 - M`) differs;
            averaged: fid+.
        hard_kept, hard_lost: the same with the hard masks a person is shown (the kept
            :math:`c_E` edges and :math:`c_F` features are 1, everything else 0): a stricter
            test, since every other message and feature is removed.
        top_edge_touches: the strongest kept edge starts or ends on the chosen object or goal.
    """

    kept: bool
    lost: bool
    hard_kept: bool
    hard_lost: bool
    top_edge_touches: bool


def faithfulness(
    net: MaskedNet, x: Tensor, num_objects: int, result: MaskExplanation
) -> Faithfulness:
    """The figures for ``result``, an explanation of ``net``'s (the explainer's masked copy
    of the policy network) decision on the graph with node
    features ``x`` (objects first) and edges ``result.edge_index``.

    Shapes:
        - **x:** :math:`(N, F)`
    """
    pair = (result.object_index, result.goal_index)
    hard_edges = torch.zeros(result.edge_index.shape[1])
    hard_edges[result.kept_edges] = 1.0
    hard_features = torch.zeros(x.shape[1])
    hard_features[result.kept_features] = 1.0
    outcomes = []
    for edges, features in (
        (result.edge_mask, result.feature_mask),
        (hard_edges, hard_features),
    ):
        explained = _decision(net, x, num_objects, result.edge_index, edges, features)
        rest = _decision(net, x, num_objects, result.edge_index, 1.0 - edges, 1.0 - features)
        outcomes += [explained == pair, rest != pair]
    top = int(result.kept_edges[0])
    ends = {int(result.edge_index[0, top]), int(result.edge_index[1, top])}
    kept, lost, hard_kept, hard_lost = outcomes
    return Faithfulness(kept, lost, hard_kept, hard_lost, bool(ends & set(pair)))


def _decision(
    net: MaskedNet,
    x: Tensor,
    num_objects: int,
    edge_index: Tensor,
    edge_mask: Tensor,
    feature_mask: Tensor,
) -> tuple[int, int] | None:
    """The decision (node indices) on the masked graph, by the policy's own rule; categories
    come from the unmasked graph, as the policy's decoder reads them."""
    with torch.no_grad():
        logits = net(x * feature_mask, edge_index, edge_mask)
        if net.decodes_pairs:
            valid = category_compatible(x[:num_objects, 0], x[num_objects:, 0])
            scores = joint_log_probs(
                logits[:num_objects].log_softmax(0),
                net.pair_logits(x * feature_mask)[:num_objects, num_objects:],
                valid,
            )
            pair = best_pair(scores, valid)
            return None if pair is None else (pair[0], num_objects + pair[1])
    found = best_compatible_pair(
        logits[:num_objects].log_softmax(0),
        logits[num_objects:].log_softmax(0),
        x[:num_objects, 0],
        x[num_objects:, 0],
    )
    return None if found is None else (found[0], num_objects + found[1])
