"""The learned dishwasher policy: four heads read as one decision."""

from __future__ import annotations

import itertools

import torch

from manigraph_dishwasher.fixtures import TRAY_RACKS, TrayAction
from manigraph_dishwasher.planner.features import (
    FILLED_COLUMN,
    ORIENTATION_COLUMNS,
    POSITION_COLUMNS,
    TRAY_ACTIONS,
    DishGraph,
    dish_scene_to_graph,
)
from manigraph_dishwasher.planner.net import DishHeads, DishPolicyNet
from manigraph_dishwasher.rules import rack_usable
from manigraph_planner.gnn.checkpoint import CheckpointInfo
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.messages import Scene
from manigraph_shared.orientations import postures_like

__all__ = ["DishwasherGNNPolicy", "decision_from_heads"]

#: Slot category code (``features``) that each dish code fills: plate 0 -> 2, bowl 1 -> 3.
_SLOT_FOR_DISH = {0: 2, 1: 3}
#: The dish kind of each dish code.
_DISH_KIND = {0: "plate", 1: "bowl"}


class DishwasherGNNPolicy(Policy):
    """Scene → dish graph → four heads → one decision.

    The tray head's argmax decides first: a toggle is the decision (``object_id`` and
    ``goal_id`` name the rack), unless it would pull a rack out while the other one is out
    (``_pointless_toggles``: the rules let neither be loaded then). Otherwise PickAndPlace:
    the most likely pair of a dish and a slot of its kind that holds no dish (a taken slot
    is an action the world refuses; the block policy's decoder likewise keeps to
    category-compatible pairs), placed in the orientation head's argmax at that dish's node.
    A dish whose rack cannot be loaded now waits for it (``_waiting``), and while one on the
    counter waits no loaded dish is moved: with nothing else to place, the decision is the
    tray head's more likely toggle that brings a waiting dish's rack nearer to loadable.
    """

    #: A dish whose skill made no progress is passed over, whichever slot it was for, until a
    #: goal is filled: its slots are alike, and what fails is taking or turning the dish (on a
    #: crowded counter, while the plates are still there). Trying it in two slots first
    #: spent the step budget on the bowls before the plates had left the counter.
    object_escalation = 1

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

    def ranked(self, scene: Scene) -> list[Decision]:
        """The decision; each other dish that can go somewhere now, most likely first, into
        its most likely slot; then the dishes into their other slots, round by round
        (``_pairs_by_dish``); last the tray actions by the tray head. The planner takes one
        of these only after the decision made no progress (e.g. a robot that cannot turn
        that dish as asked, ``orientation_unreachable``), so one dish a robot cannot load
        does not hold up the others.

        Every placement comes before a toggle: a rack left with dishes still to go into it is
        not pulled out again (the demonstrations never do). With the toggles after the first
        round, two bowls a physical arm could not take had the top rack pushed in, and the
        other bowls went nowhere they were wanted: the recovery passes over a slot two dishes
        failed to reach, and every dish's likeliest slot was that one."""
        graph = dish_scene_to_graph(scene)
        if graph.num_objects == 0:
            return []
        with torch.inference_mode():
            heads = self.net.heads_complete(graph.x)
        first = decision_from_heads(graph, heads)
        pointless = _pointless_toggles(graph)
        toggles = [
            Decision(tray.rack_id, tray.rack_id, None, tray.family_action)
            for index in heads.tray.argsort(descending=True).tolist()
            if (tray := TRAY_ACTIONS[int(index)]) is not TrayAction.NONE
            and tray.rack_id
            and tray not in pointless
        ]
        placements = itertools.chain(*_pairs_by_dish(graph, heads))
        ranked: dict[tuple[str, str], Decision] = {}
        for decision in [first, *placements, *toggles]:
            if decision is not None:
                ranked.setdefault(decision.pair, decision)
        return list(ranked.values())


def decision_from_heads(graph: DishGraph, heads: DishHeads) -> Decision | None:
    """The decision the four heads of one graph make (see :class:`DishwasherGNNPolicy`).

    "None" (PickAndPlace) when no dish fits a free slot of a usable rack is an action the
    world would refuse, like the pairs :func:`_pair_scores` leaves out: then the tray head's
    more likely toggle is the decision (a net that has not yet learnt to pull a rack out for
    more dishes than it was shown would otherwise stop before the first move). So is a
    placement of a dish away from the rack it waits for: a plate forgotten in the bottom
    rack's turn went into the pulled-out top rack for good (0.95 at 12 dishes in the
    geometric world; 1.0 with the rule), and a bowl a physical arm failed to load before the
    top rack was pushed in went into the bottom rack. Once some dish stands in a slot (before,
    the tray head alone says which rack comes first, as demonstrated), the toggle serves a
    waiting dish (``_toggle_towards`` its rack; the likeliest waiting dish's if the tray
    head's serves none): with a bowl left lying in the top rack and both racks in, the tray
    head pulled the bottom rack out and in until the step budget was spent."""
    waiting, homes = _waiting(graph, heads)
    standing = _standing(graph)
    kept = waiting & ~standing  # dishes on the counter (or in no slot) that wait
    scores = _pair_scores(graph, heads)
    if scores is not None:
        if bool(kept.any()):  # a dish on the counter waits: toggle for it
            waiting = waiting | standing
        scores = scores.masked_fill(waiting.unsqueeze(1), float("-inf"))
        if not bool(torch.isfinite(scores).any()):
            scores = None
    tray_logits = heads.tray if scores is not None else _without_none(heads.tray)
    for pointless in _pointless_toggles(graph):
        tray_logits = _without(tray_logits, pointless)
    tray = TRAY_ACTIONS[int(tray_logits.argmax())]
    if scores is None and bool(kept.any()) and bool(standing.any()):
        serving = {_toggle_towards(graph, homes[o]) for o in torch.nonzero(kept).flatten().tolist()}
        if tray not in serving:
            likeliest = int(heads.node[: graph.num_objects].masked_fill(~kept, -torch.inf).argmax())
            tray = _toggle_towards(graph, homes[likeliest]) or tray
    if tray is not TrayAction.NONE:
        rack = tray.rack_id
        assert rack is not None
        return Decision(rack, rack, None, tray.family_action)
    assert scores is not None
    m = graph.num_goals
    flat = int(scores.flatten().argmax())
    o, g = flat // m, flat % m
    return Decision(graph.object_ids[o], graph.goal_ids[g], _orientation(graph, heads, o, g))


def _orientation(graph: DishGraph, heads: DishHeads, o: int, g: int) -> int:
    """Dish ``o`` placed into slot ``g``: the orientation head's argmax, unless the slot
    requires another (a plate on its rim: any edge down), then the slot's. Where the
    demonstrations go, the two agree; a bowl left upright in a slot by a physical turn-over,
    a state no demonstration shows, was to go into the next slot upright again."""
    head = int(heads.orientation[o].argmax())
    asked = graph.x[graph.num_objects + g, ORIENTATION_COLUMNS]
    if not bool(asked.any()):
        return head
    required = int(asked.argmax())
    kind = _DISH_KIND[int(graph.goal_codes()[o])]
    return head if head in postures_like(kind, required) else required


def _without_none(tray: torch.Tensor) -> torch.Tensor:
    """The tray logits with "none" ruled out."""
    return _without(tray, TrayAction.NONE)


def _without(tray: torch.Tensor, action: TrayAction) -> torch.Tensor:
    """The tray logits with ``action`` ruled out."""
    index = TRAY_ACTIONS.index(action)
    return tray.masked_fill(torch.arange(len(TRAY_ACTIONS)) == index, float("-inf"))


def _pointless_toggles(graph: DishGraph) -> list[TrayAction]:
    """Tray actions that pull a rack out while the other rack is out: the rules load the
    bottom rack only while the top one is in, so neither could be loaded then, and the
    demonstrations never do it. A policy reading a rack where a physical world has it (the
    physics world's racks slide 12 cm, not the 16 it was shown) once pulled the bottom rack
    out under the open top one and loaded bowls into it."""
    is_open = graph.rack_open
    pointless = []
    for tray in (TrayAction.TOGGLE_TOP, TrayAction.TOGGLE_BOTTOM):
        rack = TRAY_RACKS[tray]
        others = [other for other in is_open if other != rack]
        if rack in is_open and not is_open[rack] and any(is_open[o] for o in others):
            pointless.append(tray)
    return pointless


def _pairs_by_dish(graph: DishGraph, heads: DishHeads) -> list[list[Decision]]:
    """Rounds of pairs: each dish that fits a usable free slot, most likely dish first, in
    its most likely such slot; then each in its second most likely slot, and so on; each in
    the orientation head's argmax. A dish whose most likely free slot of all is in a rack
    that cannot be loaded now waits for that rack: offered a slot elsewhere, a plate
    refused on the counter would go into the bowls' rack, where nothing takes it out. A dish
    that stands in a slot is not offered: moving it is no progress, and while another dish
    kept failing, a plate moved from slot to slot spent the step budget (and bowls were to be
    taken out of the pushed-in top rack)."""
    scores = _pair_scores(graph, heads)
    if scores is None:
        return []
    waiting = _waiting(graph, heads)[0] | _standing(graph)
    scores = scores.masked_fill(waiting.unsqueeze(1), float("-inf"))
    dishes = scores.max(dim=1).values.argsort(descending=True).tolist()
    slots = scores.argsort(dim=1, descending=True)
    rounds = []
    for rank in range(graph.num_goals):
        pairs = [
            Decision(graph.object_ids[o], graph.goal_ids[g], _orientation(graph, heads, o, g))
            for o in dishes
            if torch.isfinite(scores[o, g := int(slots[o, rank])])
        ]
        if not pairs:
            break
        rounds.append(pairs)
    return rounds


def _waiting(graph: DishGraph, heads: DishHeads) -> tuple[torch.Tensor, list[str | None]]:
    """Which dishes wait for a rack that cannot be loaded now, and each dish's home: the
    rack most dishes of its kind stand in, else the rack of its most likely free slot of all.

    The dishes already loaded show where their kind goes: the heads, in a state no
    demonstration shows (bowls still on the counter with the bottom rack out, after the
    physical arm failed to load them while the top rack was out), rated the bottom rack's
    bowl slots best, and every later step went to bowls carried under the top rack.
    """
    anywhere = _pair_scores(graph, heads, usable_only=False)
    if anywhere is None:
        return torch.ones(graph.num_objects, dtype=torch.bool), [None] * graph.num_objects
    usable = {rack: _rack_usable(graph, rack) for rack in set(graph.goal_racks)}
    likeliest = [graph.goal_racks[int(g)] for g in anywhere.argmax(dim=1)]
    kinds = graph.goal_codes()[: graph.num_objects].tolist()
    stand_in = _racks_kinds_stand_in(graph)
    homes = [stand_in.get(k, rack) for k, rack in zip(kinds, likeliest, strict=True)]
    return torch.tensor([not usable[home] for home in homes], dtype=torch.bool), homes


def _toggle_towards(graph: DishGraph, rack: str | None) -> TrayAction | None:
    """The toggle that brings ``rack`` nearer to being loadable: the other rack pushed in if
    it is out (the bottom rack is loaded only while the top one is in; neither while the
    other is out), else ``rack`` pulled out. None for no rack, or one loadable now."""
    for tray, other in TRAY_RACKS.items():
        if rack is not None and other != rack and graph.rack_open.get(other, False):
            return tray
    for tray, own in TRAY_RACKS.items():
        if own == rack and not graph.rack_open.get(own, False):
            return tray
    return None


def _racks_kinds_stand_in(graph: DishGraph) -> dict[int, str]:
    """For each dish kind (code) some dishes of which stand in slots: the rack most of them
    stand in (a dish stands in the filled slot nearest it)."""
    k = graph.num_objects
    filled = [g for g in range(graph.num_goals) if graph.x[k + g, FILLED_COLUMN] != 0]
    if not filled:
        return {}
    slots = graph.x[[k + g for g in filled], POSITION_COLUMNS]
    counts: dict[int, dict[str, int]] = {}
    kinds = graph.goal_codes()[:k].tolist()
    for o in torch.nonzero(_standing(graph)).flatten().tolist():
        nearest = int((slots - graph.x[o, POSITION_COLUMNS]).norm(dim=1).argmin())
        rack = graph.goal_racks[filled[nearest]]
        if rack is not None:
            tally = counts.setdefault(kinds[o], {})
            tally[rack] = tally.get(rack, 0) + 1
    return {kind: max(tally, key=lambda r: tally[r]) for kind, tally in counts.items()}


def _standing(graph: DishGraph) -> torch.Tensor:
    """Which dishes stand in a slot."""
    return graph.x[: graph.num_objects, FILLED_COLUMN] != 0


def _pair_scores(
    graph: DishGraph, heads: DishHeads, usable_only: bool = True
) -> torch.Tensor | None:
    """Log-likelihood of each (dish, slot) pair, -inf where the slot cannot take the dish
    now (with ``usable_only=False``: where it holds a dish or another kind's); None if no
    pair is left."""
    k, m = graph.num_objects, graph.num_goals
    codes = graph.goal_codes()
    object_logp = heads.node[:k].log_softmax(0)
    goal_logp = heads.node[k : k + m].log_softmax(0)
    free = graph.x[k : k + m, FILLED_COLUMN] == 0
    if usable_only:
        free &= _usable_slots(graph)
    wanted = torch.tensor([_SLOT_FOR_DISH[int(c)] for c in codes[:k]])
    fits = (codes[k : k + m].unsqueeze(0) == wanted.unsqueeze(1)) & free.unsqueeze(0)
    if not bool(fits.any()):
        return None
    return (object_logp.unsqueeze(1) + goal_logp.unsqueeze(0)).masked_fill(~fits, float("-inf"))


def _usable_slots(graph: DishGraph) -> torch.Tensor:
    """Which goal nodes are slots of a rack that can be loaded now."""
    return torch.tensor([_rack_usable(graph, rack) for rack in graph.goal_racks], dtype=torch.bool)


def _rack_usable(graph: DishGraph, rack: str | None) -> bool:
    """A slot of ``rack`` can be loaded now, by the rack rule (``rules.rack_usable``: the rack
    is out, and for the bottom rack the top one is in); a slot without a rack always."""
    return rack is None or rack_usable(rack, graph.rack_open)
