"""Explanations in the task's terms: a deciding attribute is named, equal values never given
as a reason (issue 43, item 6)."""

from __future__ import annotations

import re
from typing import Any

import torch

from manigraph_planner.explain import SceneExplainer
from manigraph_planner.explain.sentence import attribute_of, sentence
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.messages import ExplainedEdge, Scene, SceneGoal, SceneObject, Vector3

PAPER = ("category", "x", "y", "z", "filled")


def obj(name: str, x: float, **attributes: str | float) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=-0.2, z=0.02),
        size=Vector3(x=0.04, y=0.04, z=0.04),
        attributes=attributes,
    )


def goal(name: str, x: float, **accepts: Any) -> SceneGoal:
    return SceneGoal(
        id=name, category="block", position=Vector3(x=x, y=0.2, z=0.02), accepts=accepts
    )


COLOURS = Scene(
    episode_id="t",
    stamp=1.0,
    sequence=0,
    objects=[obj("block_3", 0.4, colour="red"), obj("block_1", 0.5, colour="blue")],
    goals=[goal("red_slot_1", 0.4, colour="red"), goal("blue_slot_0", 0.5, colour="blue")],
)


def equal_comparisons(text: str) -> list[str]:
    """Every "a 0 vs b 0" in ``text`` whose two values are the same."""
    found = re.findall(r"(\S+) (\S+) vs (\S+) ([^,;)\s]+)", text)
    return [f"{a} {v} vs {b} {w}" for a, v, b, w in found if v == w]


def test_feature_columns_belong_to_their_attribute() -> None:
    assert [attribute_of(c) for c in ("filled", "colour=red", "colour:any", "size_y", "id=p")] == [
        None,
        "colour",
        "colour",
        "size",
        "id",
    ]


def test_a_deciding_attribute_names_the_object_and_what_the_goal_accepts() -> None:
    text = sentence(
        "block_3",
        "red_slot_1",
        [ExplainedEdge(src="block_3", dst="red_slot_1", weight=0.9)],
        ["colour=red", "colour:any"],
        ("block_1", "blue_slot_0"),
        scene=COLOURS,
    )
    assert text.startswith(
        "block_3 (colour red) to red_slot_1 (accepts colour red) was chosen, rather than "
        "block_1 (colour blue) or blue_slot_0 (accepts colour blue), because of the relation "
        "block_3→red_slot_1; most important feature: colour"
    ), text
    assert "then colour" not in text  # its two columns are one attribute


def test_an_attribute_both_rivals_share_is_no_reason() -> None:
    both_red = COLOURS.model_copy(
        update={"objects": [obj("block_3", 0.4, colour="red"), obj("block_1", 0.5, colour="red")]}
    )
    text = sentence("block_3", "red_slot_1", [], ["colour=red"], ("block_1", None), scene=both_red)
    assert (
        text == "block_3 was chosen rather than block_1 (for goal red_slot_1), on its own features"
    )


def test_equal_values_are_never_given_as_a_reason() -> None:
    """Today's "most important feature: filled (block_4 0 vs block_3 0, goal_4 0 vs goal_5 0)"."""
    rows = {
        "block_4": [1, 0.40, 0.1, 0.02, 0],
        "block_3": [1, 0.50, 0.1, 0.02, 0],
        "goal_4": [2, 0.30, 0.1, 0.02, 0],
        "goal_5": [2, 0.35, 0.1, 0.02, 0],
        "goal_0": [2, 0.35, 0.1, 0.02, 1],
    }
    values = {node: [float(v) for v in row] for node, row in rows.items()}
    alone = sentence(
        "block_4", "goal_4", [], ["filled", "category"], ("block_3", "goal_5"), values, names=PAPER
    )
    assert "filled" not in alone and "category" not in alone and "most important" not in alone
    carried = sentence(
        "block_4",
        "goal_4",
        [ExplainedEdge(src="goal_0", dst="goal_4", weight=0.8)],
        ["filled", "x"],
        ("block_3", "goal_5"),
        values,
        names=PAPER,
    )
    assert "most important feature: filled (goal_0: 1, passed on to goal_4)" in carried
    assert "then x (block_4 0.4 vs block_3 0.5; goal_4 0.3 vs goal_5 0.35)" in carried
    assert equal_comparisons(carried) == []


def colour_policy() -> GNNPolicy:
    """A task policy whose node logit is its own colour=red column: red objects, and goals
    that accept red, win; relations carry nothing."""
    spec = FeatureSpec.for_task(TaskFeatures.learn([COLOURS]))
    net = PolicyNet(ModelConfig("gcn", hidden_channels=4, num_layers=1, features=spec))
    with torch.no_grad():
        for parameter in net.parameters():
            parameter.zero_()
        net.backbone.convs[0].lin_root.weight[0, spec.names.index("colour=red")] = 1.0
        net.head.weight[0, 0] = 1.0
    return GNNPolicy(net)


def test_a_task_policy_s_explanation_is_in_the_task_s_terms() -> None:
    explanation = SceneExplainer(colour_policy()).explain_scene(COLOURS)
    assert (explanation.object, explanation.goal) == ("block_3", "red_slot_1")
    assert next(iter(explanation.features)) == "colour=red"
    assert explanation.sentence.startswith(
        "block_3 (colour red) to red_slot_1 (accepts colour red) was chosen, rather than "
        "block_1 (colour blue) or blue_slot_0 (accepts colour blue)"
    ), explanation.sentence
    assert "most important feature: colour" in explanation.sentence
    assert equal_comparisons(explanation.sentence) == []
