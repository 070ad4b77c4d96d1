"""The learned dishwasher policy: four heads read as one decision."""

from __future__ import annotations

import torch

from manigraph_planner.gnn.checkpoint import CheckpointInfo
from manigraph_planner.gnn.dish_features import (
    FILLED_COLUMN,
    TRAY_ACTIONS,
    DishGraph,
    dish_scene_to_graph,
)
from manigraph_planner.gnn.models.dish_net import DishHeads, DishPolicyNet
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.messages import TRAY_RACKS, Scene, TrayAction

__all__ = ["DishwasherGNNPolicy", "decision_from_heads"]

#: Slot category code (dish_features) that each dish code fills: plate 0 -> 2, bowl 1 -> 3.
_SLOT_FOR_DISH = {0: 2, 1: 3}


class DishwasherGNNPolicy(Policy):
    """Scene → dish graph → four heads → one decision.

    The tray head's argmax decides first: a toggle is the decision (``object_id`` and
    ``goal_id`` name the rack). Otherwise PickAndPlace: the most likely pair of a dish and a
    slot of its kind that holds no dish (a taken slot is an action the world refuses; the
    block policy's decoder likewise keeps to category-compatible pairs), placed in the
    orientation head's argmax at that dish's node.
    """

    def __init__(self, net: DishPolicyNet, info: CheckpointInfo | None = None) -> None:
        torch.set_num_threads(1)
        self.net = net.eval()
        self.info = info
        self.name = f"gnn-dishwasher-{net.architecture}"

    def decide(self, scene: Scene) -> Decision | None:
        graph = dish_scene_to_graph(scene)
        if graph.num_objects == 0:
            return None
        with torch.inference_mode():
            heads = self.net.heads_complete(graph.x)
        return decision_from_heads(graph, heads)


def decision_from_heads(graph: DishGraph, heads: DishHeads) -> Decision | None:
    """The decision the four heads of one graph make (see :class:`DishwasherGNNPolicy`)."""
    tray = TRAY_ACTIONS[int(heads.tray.argmax())]
    if tray is not TrayAction.NONE:
        rack = tray.rack_id
        assert rack is not None
        return Decision(rack, rack, None, tray)
    k, m = graph.num_objects, graph.num_goals
    codes = graph.goal_codes()
    object_logp = heads.node[:k].log_softmax(0)
    goal_logp = heads.node[k : k + m].log_softmax(0)
    free = graph.x[k : k + m, FILLED_COLUMN] == 0
    usable = torch.tensor(
        [_rack_usable(graph, rack) for rack in graph.goal_racks], dtype=torch.bool
    )
    free &= usable
    wanted = torch.tensor([_SLOT_FOR_DISH[int(c)] for c in codes[:k]])
    fits = (codes[k : k + m].unsqueeze(0) == wanted.unsqueeze(1)) & free.unsqueeze(0)
    if not bool(fits.any()):
        return None
    scores = (object_logp.unsqueeze(1) + goal_logp.unsqueeze(0)).masked_fill(~fits, float("-inf"))
    flat = int(scores.flatten().argmax())
    o, g = flat // m, flat % m
    orientation = int(heads.orientation[o].argmax())
    return Decision(graph.object_ids[o], graph.goal_ids[g], orientation)


def _rack_usable(graph: DishGraph, rack: str | None) -> bool:
    """A slot of ``rack`` can be loaded now: the rack is out, and for the bottom rack the top
    one is in (a slot without a rack is always usable)."""
    if rack is None:
        return True
    top = TRAY_RACKS[TrayAction.TOGGLE_TOP]
    if not graph.rack_open.get(rack, False):
        return False
    return rack == top or not graph.rack_open.get(top, False)
