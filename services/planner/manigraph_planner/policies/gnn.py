"""The learned policy of the paper: a GNN scores every node, argmax object and argmax goal."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor

from manigraph_planner.family import family_for_heads
from manigraph_planner.gnn.checkpoint import CheckpointInfo, load_checkpoint
from manigraph_planner.gnn.features import GraphState, scene_to_graph
from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.pair_decoder import (
    best_pair,
    category_compatible,
    joint_log_probs,
    ranked_pairs,
)
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.messages import Scene

__all__ = [
    "GNNPolicy",
    "Probabilities",
    "decision_from_logits",
    "load_gnn_policy",
    "ranked_compatible_pairs",
]


@dataclass(frozen=True)
class Probabilities:
    """The policy's two distributions for one scene.

    ``object_probs[k]`` belongs to ``graph.object_ids[k]`` and ``goal_probs[l]`` to
    ``graph.goal_ids[l]``; each sums to 1 (or is empty when there is no such node).
    """

    graph: GraphState
    node_logits: Tensor
    object_probs: Tensor
    goal_probs: Tensor

    def objects(self) -> dict[str, float]:
        return dict(zip(self.graph.object_ids, self.object_probs.tolist(), strict=True))

    def goals(self) -> dict[str, float]:
        return dict(zip(self.graph.goal_ids, self.goal_probs.tolist(), strict=True))


class GNNPolicy(Policy):
    """Scene → graph state → node logits → the most likely compatible (object, goal) pair.

    The paper reads the node logits as two independent softmaxes and takes each argmax. We
    take the argmax of ``log p(o) + log p(g)`` over pairs whose categories match (a block to a
    block goal, a cover to a cover goal). Whenever the two independent argmaxes are compatible
    (always, on the training distribution) this is the same decision; it differs only where
    the paper's decoder would send a block to a cover's storage place, an action PickAndPlace
    can never complete (e.g. box rearrangement before the second box is opened). Ties go to
    the node that comes first (scene order), so decisions are deterministic.
    A policy with a task's feature spec also takes only pairs whose goal accepts the object,
    as the scene's own columns say (``TaskFeatures.admits``):
    the task file states that rule; which pair of those comes first is what was learned.
    ``accepts_filter = False`` (``--accepts-filter off``) drops that filter, so the network's
    own choice is what is judged (docs/training.md).
    A network with a ``pairs`` decoder (``ModelConfig.decoder``) scores the pairs itself:
    the same filters, then the argmax of its pair logits (:meth:`pair_scores`).
    Sets torch to one thread: a single small graph is latency-bound, and the planner shares
    a 2-core machine with the simulator. For the same reason the network runs its dense path
    for one complete graph (:meth:`PolicyNet.forward_complete`) rather than PyG message
    passing over :math:`N (N - 1)` edges.

    Args:
        net: a trained :class:`PolicyNet`; switched to eval mode.
        info: the checkpoint's provenance, if it came from one.
    """

    def __init__(self, net: PolicyNet, info: CheckpointInfo | None = None) -> None:
        torch.set_num_threads(1)
        self.net = net.eval()
        self.info = info
        self.name = f"gnn-{net.architecture}"
        self.accepts_filter = True if net.config.feature_spec.task is not None else None

    @classmethod
    def from_checkpoint(cls, path: str | Path) -> GNNPolicy:
        """Raises :class:`~manigraph_shared.errors.PolicyError` for a bad checkpoint."""
        net, info = load_checkpoint(path, message_passing=False)
        return cls(net, info)

    def graph(self, scene: Scene) -> GraphState:
        """``scene`` as this policy's graph state: the paper's five columns, or its task's
        (``PolicyError`` for a value outside the checkpoint's vocabulary, naming it)."""
        return scene_to_graph(scene, self.net.config.feature_spec)

    def admitted(self, graph: GraphState) -> Tensor | None:
        """Which (object, goal) node pairs the task's accepts allow, or None: any (no task
        columns, or the filter turned off)."""
        task = self.net.config.feature_spec.task
        if task is None or not self.accepts_filter:
            return None
        k = graph.num_objects
        return task.admits(graph.x[:k], graph.x[k:])

    def node_logits(self, graph: GraphState) -> Tensor:
        """The network's node logits for ``graph``, a complete graph like every graph state,
        computed by the dense path (:meth:`PolicyNet.forward_complete`): same parameters and
        maths as PyG message passing on ``graph.edge_index``, without per-edge tensors."""
        with torch.inference_mode():
            return self.net.forward_complete(graph.x)

    def pair_scores(self, graph: GraphState) -> tuple[Tensor, Tensor]:
        r"""A ``pairs`` decoder's :math:`\log p(o) + \log p(g \mid o)`
        (:mod:`~manigraph_planner.gnn.pair_decoder`), and the pairs it may take:
        category-compatible, and admitted by the accepts filter where it is on.

        Shapes: both :math:`(K, L)`."""
        k = graph.num_objects
        with torch.inference_mode():
            node_logits, pair_logits = self.net.pairs_complete(graph.x)
        valid = category_compatible(graph.x[:k, 0], graph.x[k:, 0])
        admitted = self.admitted(graph)
        if admitted is not None:
            valid = valid & admitted
        joint = joint_log_probs(node_logits[:k].log_softmax(0), pair_logits[:k, k:], valid)
        return joint, valid

    def probabilities(self, scene: Scene) -> Probabilities:
        graph = self.graph(scene)
        logits = self.node_logits(graph)
        k = graph.num_objects
        if self.net.decodes_pairs and 0 < k < graph.num_nodes:
            # the joint's marginals over the pairs it may take: how likely each object
            # (goal) is to be in the chosen pair
            scores, valid = self.pair_scores(graph)
            joint = scores.masked_fill(~valid, float("-inf")).flatten().softmax(0)
            joint = joint.view_as(scores).nan_to_num(0.0)
            return Probabilities(graph, logits, joint.sum(1), joint.sum(0))
        return Probabilities(graph, logits, logits[:k].softmax(0), logits[k:].softmax(0))

    def decide(self, scene: Scene) -> Decision | None:
        graph = self.graph(scene)
        k = graph.num_objects
        if k == 0 or k == graph.num_nodes:
            return None
        if self.net.decodes_pairs:
            pair = best_pair(*self.pair_scores(graph))
            if pair is None:
                return None
            return Decision(graph.object_ids[pair[0]], graph.goal_ids[pair[1]])
        return decision_from_logits(graph, self.node_logits(graph), self.admitted(graph))

    def ranked(self, scene: Scene) -> list[Decision]:
        """Every compatible pair by ``log p(o) + log p(g)`` (a ``pairs`` decoder: by its
        ``log p(o, g)``), most likely first (the first is :meth:`decide`'s; ties in scene
        order)."""
        graph = self.graph(scene)
        k = graph.num_objects
        if k == 0 or k == graph.num_nodes:
            return []
        if self.net.decodes_pairs:
            found = ranked_pairs(*self.pair_scores(graph))
            return [Decision(graph.object_ids[o], graph.goal_ids[g]) for o, g in found]
        logits = self.node_logits(graph)
        pairs = ranked_compatible_pairs(
            logits[:k].log_softmax(0),
            logits[k:].log_softmax(0),
            graph.x[:k, 0],
            graph.x[k:, 0],
            self.admitted(graph),
        )
        return [Decision(graph.object_ids[o], graph.goal_ids[g]) for o, g in pairs]


def decision_from_logits(
    graph: GraphState, node_logits: Tensor, admitted: Tensor | None = None
) -> Decision | None:
    """The most likely compatible (object, goal) pair of ``graph`` under ``node_logits``
    (see :class:`GNNPolicy`); None when the graph has no compatible pair. ``admitted``
    (:math:`(K, L)` bool, optional): the pairs a task's accepts allow.

    Shapes:
        - **node_logits:** :math:`(N,)`, objects first, as in ``graph``
    """
    k = graph.num_objects
    pair = best_compatible_pair(
        node_logits[:k].log_softmax(0),
        node_logits[k:].log_softmax(0),
        graph.x[:k, 0],
        graph.x[k:, 0],
        admitted,
    )
    if pair is None:
        return None
    object_index, goal_index = pair
    return Decision(graph.object_ids[object_index], graph.goal_ids[goal_index])


def best_compatible_pair(
    object_logp: Tensor,
    goal_logp: Tensor,
    object_codes: Tensor,
    goal_codes: Tensor,
    admitted: Tensor | None = None,
) -> tuple[int, int] | None:
    """Argmax of ``object_logp[o] + goal_logp[g]`` over category-compatible pairs (paper codes:
    block 1 fills block-goal 2, cover 0 fills cover-goal 3), and ``admitted`` ones where
    given. The first maximal pair wins; None when no pair is compatible."""
    compatible = _compatible(object_codes, goal_codes, admitted)
    if not bool(compatible.any()):
        return None
    scores = object_logp.unsqueeze(1) + goal_logp.unsqueeze(0)
    scores = scores.masked_fill(~compatible, float("-inf"))
    flat = int(scores.flatten().argmax())  # the first maximal index: deterministic
    return flat // scores.shape[1], flat % scores.shape[1]


def ranked_compatible_pairs(
    object_logp: Tensor,
    goal_logp: Tensor,
    object_codes: Tensor,
    goal_codes: Tensor,
    admitted: Tensor | None = None,
) -> list[tuple[int, int]]:
    """Every category-compatible (object, goal) index pair, by ``object_logp[o] +
    goal_logp[g]`` from the most likely; equal scores keep row-major order, so the first pair
    is :func:`best_compatible_pair`'s."""
    compatible = _compatible(object_codes, goal_codes, admitted)
    scores = (object_logp.unsqueeze(1) + goal_logp.unsqueeze(0)).flatten()
    order = torch.sort(scores, descending=True, stable=True).indices
    width = goal_logp.shape[0]
    flat = compatible.flatten()
    return [(int(i) // width, int(i) % width) for i in order if bool(flat[i])]


#: Object category code -> the code of the goals it can fill (paper: cover 0 -> 3, block 1 -> 2).
_GOAL_CODE_FOR = torch.tensor([3.0, 2.0])


def _compatible(object_codes: Tensor, goal_codes: Tensor, admitted: Tensor | None) -> Tensor:
    """``(K, L)``: categories that fit, and the task's accepts where ``admitted`` is given."""
    compatible = goal_codes.round().unsqueeze(0) == _GOAL_CODE_FOR[
        object_codes.round().long()
    ].unsqueeze(1)
    return compatible if admitted is None else compatible & admitted


def load_gnn_policy(path: Path) -> Policy:
    """The ``.pt`` policy file loader (registered in ``policies.base.POLICY_FILE_LOADERS``):
    a :class:`GNNPolicy`, or the policy of the family whose heads the checkpoint has
    (``PlannerFamily.policy``).
    Its network holds the weights for the dense path only: serving never imports PyG (the
    explainer rebuilds the message-passing network it needs)."""
    net, info = load_checkpoint(path, message_passing=False)
    policy = family_for_heads(net.config.heads).part("policy")
    if policy is None:
        return GNNPolicy(net, info)
    loaded: Policy = policy(net, info)
    return loaded
