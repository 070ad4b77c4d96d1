"""From a scene and a GNN policy's choice to a readable ``Explanation`` message."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence

import torch
from torch import Tensor

from manigraph_planner.explain.config import ExplainerConfig
from manigraph_planner.explain.masks import MaskExplainer, MaskExplanation
from manigraph_planner.explain.sentence import sentence
from manigraph_planner.gnn.features import FEATURE_SPEC, GraphState, fully_connected_edge_index
from manigraph_planner.policies.base import Policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import (
    EXPLAINER_BUSY,
    ExplainedEdge,
    ExplainedNode,
    Explanation,
    Scene,
)

__all__ = ["SceneExplainer", "sentence", "to_message"]


class SceneExplainer:
    """Explains a GNN policy's decisions on scenes; safe to call from several threads.

    What one request may cost is bounded: a scene with more than ``config.max_nodes`` visible
    nodes is refused (``scene_too_large``) before anything is computed, an explanation runs
    for at most ``config.deadline_seconds`` (``explain_deadline``), and one explanation runs at
    a time: a request that finds the explainer busy is refused at once (``explainer_busy``)
    unless it asks to wait (the planner's own ``--explain-decisions``). Zenoh does not tell a
    queryable which client asked, so "one at a time per client" is kept as one at a time.

    Args:
        policy: the policy whose decisions are explained; only GNN policies can be.
        config: the mask optimisation's settings.

    Raises:
        PolicyError: ``policy`` is not a GNN policy.
    """

    def __init__(self, policy: Policy, config: ExplainerConfig | None = None) -> None:
        if not isinstance(policy, GNNPolicy):
            raise PolicyError(
                f"policy: '{policy.name}' is not a GNN policy; only GNN policies "
                "can be explained (start the planner with --policy CHECKPOINT.pt)"
            )
        self.policy = policy
        self.masks = MaskExplainer(policy.net, config)
        self._lock = threading.Lock()

    def warm_up(self) -> None:
        """Run two steps of the optimisation on a 4-node graph: what a first explanation
        costs beyond the later ones (autograd's and Adam's first calls) is paid here, not in
        the first query's time."""
        x = torch.zeros(4, self.policy.net.config.input_size)
        edge_index = fully_connected_edge_index(4)
        self.masks.explain(x, edge_index, 2, 0, 2, steps=2)

    def explain_scene(
        self, scene: Scene, seed: int | None = None, wait: bool = True
    ) -> Explanation:
        """Decide on ``scene`` as the policy would, then explain that decision."""
        self.check_size(scene)
        decision = self.policy.decide(scene)
        if decision is None:
            raise PolicyError(
                f"scene: the policy has nothing to decide on scene {scene.sequence} "
                f"of episode '{scene.episode_id}' (no object fits a free goal)"
            )
        return self.explain(scene, decision.object_id, decision.goal_id, None, seed, wait)

    def check_size(self, scene: Scene) -> None:
        """Raises ``PolicyError`` (``scene_too_large``) for a scene over ``max_nodes``."""
        self.masks.config.check_size(scene)

    def explain(
        self,
        scene: Scene,
        object_id: str,
        goal_id: str,
        decision_id: str | None = None,
        seed: int | None = None,
        wait: bool = True,
    ) -> Explanation:
        """Explain choosing ``object_id`` for ``goal_id`` on ``scene``; with ``wait`` False,
        refuse at once if another explanation is running.

        Raises:
            PolicyError: the object or goal is not a visible node of the scene, the scene is
                too large, the explainer is busy or the deadline passed.
        """
        self.check_size(scene)
        graph = self.policy.graph(scene)  # the policy's columns: a task's attributes too
        if object_id not in graph.object_ids:
            raise PolicyError(f"object: '{object_id}' is not a visible object of the scene")
        if goal_id not in graph.goal_ids:
            raise PolicyError(f"goal: '{goal_id}' is not a visible goal of the scene")
        object_index = graph.object_ids.index(object_id)
        goal_index = graph.num_objects + graph.goal_ids.index(goal_id)
        seed = self.masks.config.seed if seed is None else seed
        config = self.masks.config
        if not self._lock.acquire(blocking=True, timeout=config.deadline_seconds if wait else 0):
            raise PolicyError(f"{EXPLAINER_BUSY}: one explanation at a time; ask again later")
        try:
            deadline = time.monotonic() + config.deadline_seconds
            result = self.masks.explain(
                graph.x,
                graph.edge_index,
                graph.num_objects,
                object_index,
                goal_index,
                seed,
                deadline=deadline,
            )
        finally:
            self._lock.release()
        logits = self.policy.node_logits(graph)
        goal_scores = logits[graph.num_objects :]
        if self.policy.net.decodes_pairs:  # the best other goal for the chosen object
            scores, valid = self.policy.pair_scores(graph)
            goal_scores = scores[object_index].masked_fill(~valid[object_index], float("-inf"))
        rivals = (
            _runner_up(logits[: graph.num_objects], object_index, graph.object_ids),
            _runner_up(goal_scores, goal_index - graph.num_objects, graph.goal_ids),
        )
        names = self.policy.net.config.feature_spec.names
        return to_message(result, graph, scene, self.policy.name, decision_id, seed, rivals, names)


def to_message(
    result: MaskExplanation,
    graph: GraphState,
    scene: Scene,
    policy: str,
    decision_id: str | None,
    seed: int,
    rivals: tuple[str | None, str | None] = (None, None),
    names: Sequence[str] = FEATURE_SPEC.names,
) -> Explanation:
    """The contract message for ``result``: node indices become the scene's ids, feature
    columns their ``names`` (the policy's spec); ``rivals`` (the runner-up object and goal)
    make the sentence contrastive."""
    ids = [*graph.object_ids, *graph.goal_ids]
    edges = [
        ExplainedEdge(
            src=ids[int(result.edge_index[0, e])],
            dst=ids[int(result.edge_index[1, e])],
            weight=round(float(result.edge_mask[e]), 6),
        )
        for e in result.kept_edges.tolist()
    ]
    features = {
        names[j]: round(float(result.feature_mask[j]), 6) for j in result.feature_order.tolist()
    }
    nodes = [
        ExplainedNode(id=o.id, category=o.category.value, position=o.position)
        for o in scene.objects
        if o.visible
    ] + [
        ExplainedNode(id=g.id, category=f"{g.category.value}-goal", position=g.position)
        for g in scene.goals
        if g.visible
    ]
    chosen_object = ids[result.object_index]
    chosen_goal = ids[result.goal_index]
    top_features = [names[j] for j in result.kept_features.tolist()]
    return Explanation(
        decision_id=decision_id,
        episode_id=scene.episode_id,
        scene_sequence=scene.sequence,
        policy=policy,
        object=chosen_object,
        goal=chosen_goal,
        edges=edges,
        features=features,
        nodes=nodes,
        sentence=sentence(
            chosen_object,
            chosen_goal,
            edges,
            top_features,
            rivals,
            {node: graph.x[i].tolist() for i, node in enumerate(ids)},
            scene,
            names,
        ),
        fidelity=result.fidelity,
        seed=seed,
        stamp=time.time(),
    )


def _runner_up(logits: Tensor, chosen: int, ids: list[str]) -> str | None:
    """The node with the highest logit after the chosen one (None when it has no rival)."""
    if len(ids) < 2:
        return None
    others = logits.clone()
    others[chosen] = float("-inf")
    return ids[int(others.argmax())]
