"""An explanation in words, in the task's terms, and never with equal values as a reason.

The sentence is contrastive: the chosen object and goal against the runner-ups the policy
ranked second, then the kept relations, then the kept features with what tells the nodes
apart. Two rules keep it honest:

* **A feature is a reason only where its values differ.** For each kept feature the sentence
  shows the chosen node against its rival where the two differ; where they are equal (both
  unfilled), the feature can still decide through a relation, so it shows the value a kept
  relation brings from another node when that differs from the chosen node's; a kept feature
  that differs nowhere is left out of the sentence (it stays in ``features``). Today's
  "most important feature: filled (block_4 0 vs block_3 0, goal_4 0 vs goal_5 0)" gave equal
  values as the reason.
* **An attribute that decides is named.** When a kept feature is a column of a task's
  attribute (``colour=red``, ``colour:any``, ``size_x``, ``id=part_2``; see
  :mod:`~manigraph_planner.gnn.task_features`) and the attribute tells the chosen object or
  goal from its rival, the nodes are described by it: "block_3 (colour red) to red_slot_1
  (accepts colour red) was chosen, rather than block_1 (colour blue) or blue_slot_0 (accepts
  colour blue)".

Two more say what the goals were:

* **Every key of a goal's ``accepts`` is named** wherever the goal is (``red_slot_1 (accepts
  colour red and size 4 x 4 x 4 cm)``), not only the key that decided; a goal's own
  attributes (a bin's colour) are named where that attribute decides.
* **A goal the policy could have used, and that was free, is said**: one that is not filled,
  has nothing over it, stands on goals already done, and accepts the chosen object
  ("red_slot_2, which also accepts colour red, was free"; without ``accepts``, "goal_5 was
  free too"). At most :data:`FREE_NAMED` are named, then how many more.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from manigraph_planner.gnn.features import FEATURE_SPEC
from manigraph_planner.gnn.task_features import GOAL_PREFIX
from manigraph_planner.policies.matching import GoalMatching, goal_admits
from manigraph_planner.scene_geometry import SceneGeometry
from manigraph_shared.messages import ExplainedEdge, Scene, SceneGoal

__all__ = ["FREE_NAMED", "attribute_of", "free_goals", "sentence"]

#: Free goals named at most; more are counted ("and 3 more").
FREE_NAMED = 3

_SIZE_COLUMNS = frozenset({"size_x", "size_y", "size_z", "size:any"})
_CATEGORIES = {code: name for name, code in FEATURE_SPEC.category_codes}


def attribute_of(column: str) -> str | None:
    """The task attribute a feature column belongs to (``colour=red`` -> ``colour``,
    ``size_y`` -> ``size``, a goal's own ``goal.colour=red`` -> ``colour``), or None for the
    paper's five columns."""
    if column in FEATURE_SPEC.names:
        return None
    if column in _SIZE_COLUMNS:
        return "size"
    return column.removeprefix(GOAL_PREFIX).split("=", 1)[0].removesuffix(":any")


@dataclass(frozen=True)
class _Nodes:
    """What the sentence reads of the graph: feature rows by node, and the scene's entities."""

    names: Sequence[str]
    values: dict[str, list[float]] | None
    scene: Scene | None

    def value(self, node: str, column: str) -> str | None:
        """The node's value in ``column`` as shown (a category by its name)."""
        if self.values is None or node not in self.values or column not in self.names:
            return None
        number = self.values[node][list(self.names).index(column)]
        if column == "category":
            return _CATEGORIES.get(round(number), f"{number:.3g}")
        return f"{number:.3g}"

    def described(self, node: str, attribute: str) -> str | None:
        """``colour red`` for an object, ``accepts colour red`` for a goal; None if the node
        is neither (or there is no scene)."""
        if self.scene is None:
            return None
        for obj in self.scene.objects:
            if obj.id == node:
                if attribute == "size":
                    return f"size {_size(obj.size.as_tuple())}"
                if attribute == "id":
                    return f"id {obj.id}"
                value = obj.attributes.get(attribute)
                return f"no {attribute}" if value is None else f"{attribute} {_word(value)}"
        goal = self.goal(node)
        if goal is None:
            return None
        if attribute in goal.attributes and attribute not in goal.accepts:
            return f"{attribute} {_word(goal.attributes[attribute])}"
        accepted = goal.accepts.get(attribute)
        if accepted is None:
            return f"accepts any {attribute}"
        return f"accepts {_accepted(attribute, accepted)}"

    def goal(self, node: str | None) -> SceneGoal | None:
        if self.scene is None or node is None:
            return None
        return next((g for g in self.scene.goals if g.id == node), None)

    def goal_words(self, node: str, deciding: Sequence[str]) -> list[str]:
        """What to say of a goal: its own deciding attributes, then every key it accepts,
        then ``accepts any colour`` for a deciding attribute it neither carries nor lists."""
        goal = self.goal(node)
        if goal is None:
            return []
        own = [
            f"{a} {_word(goal.attributes[a])}"
            for a in deciding
            if a in goal.attributes and a not in goal.accepts
        ]
        listed = [_accepted(key, value) for key, value in goal.accepts.items()]
        words = [*own, *(["accepts " + _join(listed)] if listed else [])]
        return words + [
            f"accepts any {a}"
            for a in deciding
            if a not in goal.attributes and a not in goal.accepts
        ]


def sentence(
    chosen_object: str,
    chosen_goal: str,
    edges: list[ExplainedEdge],
    top_features: list[str],
    rivals: tuple[str | None, str | None] = (None, None),
    values: dict[str, list[float]] | None = None,
    scene: Scene | None = None,
    names: Sequence[str] = FEATURE_SPEC.names,
) -> str:
    """A contrastive reading: "block_0 was chosen rather than block_3 (for goal goal_8 rather
    than goal_2), because of the relations block_0→goal_8 and goal_7→goal_8; most important
    feature: filled (block_0 0 vs block_3 1)". ``values`` holds each node's feature row
    (``names`` order); ``scene`` its attributes, for a task policy's columns."""
    rival_object, rival_goal = rivals
    nodes = _Nodes(names, values, scene)
    pairs = [(chosen_object, rival_object), (chosen_goal, rival_goal)]
    deciding = [
        attribute
        for attribute in dict.fromkeys(filter(None, map(attribute_of, top_features)))
        if _tells_apart(nodes, attribute, pairs)
    ]
    text = _opening(nodes, deciding, chosen_object, chosen_goal, rival_object, rival_goal)
    relations = [f"{e.src}→{e.dst}" for e in edges]
    if relations:
        noun = "relation" if len(relations) == 1 else "relations"
        text += f", because of the {noun} {_join(relations)}"
    else:
        text += ", on its own features"
    reasons: list[str] = []
    for name in dict.fromkeys(attribute_of(f) or f for f in top_features):
        if name in deciding:
            reasons.append(name)  # its values are in the opening
        elif name in names:
            reason = _paper_reason(nodes, name, pairs, edges)
            if reason is not None:
                reasons.append(reason)
    for rank, reason in enumerate(reasons):
        text += ("; most important feature: " if rank == 0 else "; then ") + reason
    if scene is not None:
        text += _free_clause(scene, chosen_object, chosen_goal)
    return text[:1024]


def free_goals(scene: Scene, chosen_object: str, chosen_goal: str) -> list[SceneGoal]:
    """Goals other than ``chosen_goal`` the policy could have sent ``chosen_object`` to: not
    filled, nothing over them, every goal under them done, and accepting the object."""
    obj = next((o for o in scene.objects if o.id == chosen_object), None)
    if obj is None:
        return []
    matching = GoalMatching(scene, SceneGeometry(scene))
    return [
        goal
        for goal in matching.goals
        if goal.id != chosen_goal and goal_admits(goal, obj) and matching.fillable(goal)
    ]


def _free_clause(scene: Scene, chosen_object: str, chosen_goal: str) -> str:
    """``; red_slot_2, which also accepts colour red, was free`` (one clause per way of
    saying what the goals share with the chosen one), or nothing."""
    chosen = next((g for g in scene.goals if g.id == chosen_goal), None)
    if chosen is None:
        return ""
    said: dict[tuple[str, str], list[str]] = {}
    for goal in free_goals(scene, chosen_object, chosen_goal):
        said.setdefault(_alike(goal, chosen), []).append(goal.id)
    text = ""
    for (verb, what), ids in said.items():
        named = ids if len(ids) <= FREE_NAMED else [*ids[:FREE_NAMED], f"{len(ids) - 3} more"]
        many = len(ids) > 1
        was = "were" if many else "was"
        if not verb:
            text += f"; {_join(named)} {was} free too"
            continue
        if many:  # accepts -> accept, is -> are
            verb = verb.replace("accepts", "accept").replace("is", "are")
        text += f"; {_join(named)}, which {verb} {what}, {was} free"
    return text


def _alike(goal: SceneGoal, chosen: SceneGoal) -> tuple[str, str]:
    """What ``goal`` shares with ``chosen``, as a verb and its words: ``also accepts``,
    ``colour red`` (or ``accepts`` where what it accepts differs); where it accepts anything,
    ``is also`` and the own attributes it shares; ``("", "")`` when there is nothing to say."""
    if goal.accepts:
        listed = _join([_accepted(k, v) for k, v in goal.accepts.items()])
        also = all(chosen.accepts.get(k) == v for k, v in goal.accepts.items())
        return ("also accepts" if also else "accepts"), listed
    shared = [
        f"{name} {_word(value)}"
        for name, value in goal.attributes.items()
        if chosen.attributes.get(name) == value
    ]
    return ("is also", _join(shared)) if shared else ("", "")


def _accepted(key: str, value: object) -> str:
    """One key of an ``accepts``, in words: ``colour red``, ``size 4 x 4 x 4 cm``."""
    if key == "size" and isinstance(value, list | tuple):
        return f"size {_size(tuple(float(v) for v in value))}"
    return f"{key} {_word(value)}"


def _opening(
    nodes: _Nodes,
    deciding: list[str],
    chosen_object: str,
    chosen_goal: str,
    rival_object: str | None,
    rival_goal: str | None,
) -> str:
    if not deciding:  # the paper's columns only: the contrastive form of before

        def which(goal: str) -> str:
            said = nodes.goal_words(goal, ())
            return f"{goal}, which {', '.join(said)}," if said else goal

        text = f"{chosen_object} was chosen"
        if rival_object:
            text += f" rather than {rival_object}"
        text += f" (for goal {which(chosen_goal)}"
        if rival_goal:
            text += f" rather than {which(rival_goal)}"
        return text.removesuffix(",") + ")"

    def named(node: str) -> str:
        if nodes.goal(node) is not None:
            shown = nodes.goal_words(node, deciding)
        else:
            said = [nodes.described(node, attribute) for attribute in deciding]
            shown = [s for s in said if s]
        return f"{node} ({', '.join(shown)})" if shown else node

    text = f"{named(chosen_object)} to {named(chosen_goal)} was chosen"
    others = [named(r) for r in (rival_object, rival_goal) if r]
    return text + (f", rather than {' or '.join(others)}" if others else "")


def _tells_apart(nodes: _Nodes, attribute: str, pairs: list[tuple[str, str | None]]) -> bool:
    return any(
        rival is not None
        and nodes.described(chosen, attribute) != nodes.described(rival, attribute)
        for chosen, rival in pairs
    )


def _paper_reason(
    nodes: _Nodes, column: str, pairs: list[tuple[str, str | None]], edges: list[ExplainedEdge]
) -> str | None:
    """``filled (block_0 0 vs block_3 1)``: only comparisons whose values differ; where the
    chosen node and its rival are equal, what a kept relation brings in that differs; None
    when nothing differs (or no values are known)."""
    shown = []
    for chosen, rival in pairs:
        mine = nodes.value(chosen, column)
        theirs = nodes.value(rival, column) if rival else None
        if mine is not None and theirs is not None and mine != theirs:
            shown.append(f"{chosen} {mine} vs {rival} {theirs}")
    if not shown:
        chosen_nodes = {chosen for chosen, _ in pairs}
        sent: dict[str, tuple[str, list[str]]] = {}  # source -> (its value, chosen it reaches)
        for edge in edges:
            if edge.dst in chosen_nodes and edge.src not in chosen_nodes:
                value, there = nodes.value(edge.src, column), nodes.value(edge.dst, column)
                if value is not None and value != there:
                    sent.setdefault(edge.src, (value, []))[1].append(edge.dst)
        groups: dict[tuple[str, tuple[str, ...]], list[str]] = {}
        for source, (value, reached) in sent.items():
            groups.setdefault((value, tuple(dict.fromkeys(reached))), []).append(source)
        shown = [
            f"{_join(sources)}: {value}, passed on to {_join(list(reached))}"
            for (value, reached), sources in groups.items()
        ]
    return f"{column} ({'; '.join(shown)})" if shown else None


def _size(extents: tuple[float, ...]) -> str:
    return " x ".join(f"{v * 100:.3g}" for v in extents) + " cm"


def _word(value: object) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def _join(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]
