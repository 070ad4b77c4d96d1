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


def goal(
    name: str,
    x: float,
    filled: bool = False,
    attributes: dict[str, str | float] | None = None,
    **accepts: Any,
) -> SceneGoal:
    return SceneGoal(
        id=name,
        category="block",
        position=Vector3(x=x, y=0.2, z=0.02),
        accepts=accepts,
        filled=filled,
        attributes=attributes or {},
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
    columns = ("filled", "colour=red", "colour:any", "size_y", "id=p", "goal.colour=red")
    assert [attribute_of(c) for c in columns] == [None, "colour", "colour", "size", "id", "colour"]


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
    both_red = COLOURS.replace(
        objects=[obj("block_3", 0.4, colour="red"), obj("block_1", 0.5, colour="red")]
    )
    text = sentence("block_3", "red_slot_1", [], ["colour=red"], ("block_1", None), scene=both_red)
    assert text == (
        "block_3 was chosen rather than block_1 (for goal red_slot_1, which accepts colour red), "
        "on its own features"
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


def test_every_key_a_goal_accepts_is_named() -> None:
    sized = COLOURS.replace(
        goals=[
            goal("red_slot_1", 0.4, colour="red", size=[0.04, 0.04, 0.04]),
            goal("blue_slot_0", 0.5, colour="blue"),
        ]
    )
    text = sentence(
        "block_3", "red_slot_1", [], ["colour=red"], ("block_1", "blue_slot_0"), scene=sized
    )
    assert text.startswith(
        "block_3 (colour red) to red_slot_1 (accepts colour red and size 4 x 4 x 4 cm) was "
        "chosen, rather than block_1 (colour blue) or blue_slot_0 (accepts colour blue)"
    ), text
    plain = sentence("block_3", "red_slot_1", [], ["filled"], ("block_1", None), scene=sized)
    assert "(for goal red_slot_1, which accepts colour red and size 4 x 4 x 4 cm)" in plain


def scene_with(*goals: SceneGoal) -> Scene:
    return COLOURS.replace(goals=list(goals))


def test_a_goal_the_policy_could_have_used_is_said_to_be_free() -> None:
    one = scene_with(
        goal("red_slot_1", 0.4, colour="red"),
        goal("red_slot_2", 0.3, colour="red"),
        goal("red_slot_3", 0.2, filled=True, colour="red"),  # filled: not free
        goal("blue_slot_0", 0.5, colour="blue"),  # does not accept a red block
    )

    def said(scene: Scene) -> str:
        return sentence(
            "block_3", "red_slot_1", [], ["colour=red"], ("block_1", "blue_slot_0"), scene=scene
        )

    text = said(one)
    assert text.endswith("; red_slot_2, which also accepts colour red, was free"), text
    assert "red_slot_3" not in text and text.count("blue_slot_0") == 1
    two = scene_with(*one.goals, goal("red_slot_4", 0.1, colour="red"))
    assert said(two).endswith(
        "; red_slot_2 and red_slot_4, which also accept colour red, were free"
    )
    alone = scene_with(goal("red_slot_1", 0.4, colour="red"), goal("blue_slot_0", 0.5))
    assert said(alone).endswith("; blue_slot_0 was free too")


def test_a_free_goal_is_told_by_what_it_shares_or_what_it_accepts() -> None:
    bins = scene_with(
        goal("bin_0", 0.4, attributes={"colour": "red"}),
        goal("bin_1", 0.3, attributes={"colour": "red"}),
        goal("bin_2", 0.5, attributes={"colour": "blue"}),
        goal("any_slot", 0.2, colour="red"),
    )
    text = sentence("block_3", "bin_0", [], ["goal.colour=red"], ("block_1", "bin_2"), scene=bins)
    assert text.startswith(
        "block_3 (colour red) to bin_0 (colour red) was chosen, rather than block_1 (colour "
        "blue) or bin_2 (colour blue)"
    ), text
    assert "; bin_1, which is also colour red, was free" in text
    assert "; bin_2 was free too" in text  # it accepts any block: free, and nothing shared
    assert "; any_slot, which accepts colour red, was free" in text


def test_a_goal_with_an_object_over_it_is_not_free() -> None:
    covered = Scene(
        episode_id="t",
        stamp=1.0,
        sequence=0,
        objects=[
            obj("block_3", 0.4, colour="red"),
            SceneObject(
                id="block_1",
                category="block",
                position=Vector3(x=0.3, y=0.2, z=0.06),  # resting over red_slot_2
                size=Vector3(x=0.04, y=0.04, z=0.04),
                attributes={"colour": "blue"},
            ),
        ],
        goals=[goal("red_slot_1", 0.4, colour="red"), goal("red_slot_2", 0.3, colour="red")],
    )
    assert "free" not in sentence("block_3", "red_slot_1", [], [], scene=covered)
