"""The learned policy of the paper: a GNN scores every node, argmax object and argmax goal."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor

from manigraph_planner.gnn.checkpoint import CheckpointInfo, load_checkpoint
from manigraph_planner.gnn.features import GraphState, scene_to_graph
from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.policies.base import POLICY_FILE_LOADERS, Decision, Policy
from manigraph_shared.messages import Scene

__all__ = ["GNNPolicy", "Probabilities"]


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
    """Scene → graph state → node logits → (argmax object, argmax goal).

    Ties go to the node that comes first (scene order), so decisions are deterministic.
    Sets torch to one thread: a single small graph is latency-bound, and the planner shares
    a 2-core machine with the simulator.

    Args:
        net: a trained :class:`PolicyNet`; switched to eval mode.
        info: the checkpoint's provenance, if it came from one.
    """

    def __init__(self, net: PolicyNet, info: CheckpointInfo | None = None) -> None:
        torch.set_num_threads(1)
        self.net = net.eval()
        self.info = info
        self.name = f"gnn-{net.architecture}"

    @classmethod
    def from_checkpoint(cls, path: str | Path) -> GNNPolicy:
        """Raises :class:`~manigraph_shared.errors.PolicyError` for a bad checkpoint."""
        net, info = load_checkpoint(path)
        return cls(net, info)

    def probabilities(self, scene: Scene) -> Probabilities:
        graph = scene_to_graph(scene)
        with torch.inference_mode():
            logits = self.net(graph.x, graph.edge_index)
            k = graph.num_objects
            return Probabilities(graph, logits, logits[:k].softmax(0), logits[k:].softmax(0))

    def decide(self, scene: Scene) -> Decision | None:
        graph = scene_to_graph(scene)
        k = graph.num_objects
        if k == 0 or k == graph.num_nodes:
            return None
        with torch.inference_mode():
            logits = self.net(graph.x, graph.edge_index)
        # torch.argmax returns the first maximal index: the deterministic tie-break.
        object_index = int(logits[:k].argmax())
        goal_index = int(logits[k:].argmax())
        return Decision(graph.object_ids[object_index], graph.goal_ids[goal_index])


POLICY_FILE_LOADERS[".pt"] = GNNPolicy.from_checkpoint
