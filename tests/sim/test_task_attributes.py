"""Attributes on objects and what goals accept, from a task file to the episode's end: parsed,
drawn per seed, carried in the Scene and TaskLayout, and deciding success on the real
geometric world (issue 43)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from manigraph_blocks.sim.task_file import FileTask, parse_task_file
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest, GripperOp, RobotCommand, Scene, Vector3
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.layout_message import layout_message


def block(name: str, position: str, extra: str = "") -> str:
    return f'[[objects]]\nid = "{name}"\ncategory = "block"\nposition = {position}\n{extra}\n'


def goal(name: str, position: str, extra: str = "") -> str:
    return f'[[goals]]\nid = "{name}"\ncategory = "block"\nposition = {position}\n{extra}\n'


#: Two towers of two to swap: each goal accepts one object by id, where the other tower stands.
SWAP = (
    block("a0", "[0.45, -0.20, 0.02]")
    + block("a1", "[0.45, -0.20, 0.06]")
    + block("b0", "[0.45, 0.20, 0.02]")
    + block("b1", "[0.45, 0.20, 0.06]")
    + goal("ga0", "[0.45, 0.20, 0.02]", 'accepts = { id = "a0" }')
    + goal("ga1", "[0.45, 0.20, 0.06]", 'accepts = { id = "a1" }')
    + goal("gb0", "[0.45, -0.20, 0.02]", 'accepts = { id = "b0" }')
    + goal("gb1", "[0.45, -0.20, 0.06]", 'accepts = { id = "b1" }')
)

#: A red and a blue block, one goal for each colour.
COLOURS = (
    block("r", "[0.40, -0.20, 0.02]", 'attributes = { colour = "red", label = "bolt" }')
    + block("b", "[0.40, 0.20, 0.02]", 'attributes = { colour = "blue", weight = 2 }')
    + goal("red_goal", "[0.60, -0.10, 0.02]", 'accepts = { colour = "red" }')
    + goal("blue_goal", "[0.60, 0.10, 0.02]", 'accepts = { colour = "blue", weight = 2.0 }')
)


def command(op: GripperOp, object_id: str, position: Vector3) -> RobotCommand:
    return RobotCommand(
        command_id="c", decision_id="d", op=op, object_id=object_id, position=position, stamp=0.0
    )


def put(sim: GeometricBackend, object_id: str, position: Vector3) -> Scene:
    scene = sim.scene(0.0)
    assert scene is not None
    item = scene.object(object_id)
    assert sim.execute(command(GripperOp.PICK, item.id, item.position), 0.0).ok
    assert sim.execute(command(GripperOp.PLACE, item.id, position), 0.0).ok
    after = sim.scene(0.0)
    assert after is not None
    return after


def reset(text: str, seed: int = 0, max_steps: int = 0) -> GeometricBackend:
    sim = GeometricBackend()
    sim.reset(
        EpisodeRequest(episode_id="e", task="file", task_file=text, seed=seed, max_steps=max_steps),
        0.0,
    )
    return sim


def test_attributes_and_accepts_reach_the_layout_the_scene_and_the_task_layout() -> None:
    spec = parse_task_file(COLOURS)
    assert spec.objects[0].attributes == {"colour": "red", "label": "bolt"}
    assert spec.objects[1].attributes == {"colour": "blue", "weight": 2.0}
    assert spec.goals[1].accepts == {"colour": "blue", "weight": 2.0}
    layout = FileTask(spec).layout(np.random.default_rng(0))
    message = layout_message(layout, "e", 0.0)
    assert message.objects[0].attributes == {"colour": "red", "label": "bolt"}
    assert message.goals[0].accepts == {"colour": "red"}
    scene = reset(COLOURS).scene(0.0)
    assert scene is not None
    assert scene.object("b").attributes == {"colour": "blue", "weight": 2.0}
    assert scene.goal("blue_goal").accepts == {"colour": "blue", "weight": 2.0}
    size = parse_task_file(
        block("s", "[0.4, 0.0, 0.015]", "size = [0.03, 0.03, 0.03]")
        + goal("g", "[0.6, 0.0, 0.015]", "accepts = { size = [0.03, 0.03, 0.03] }")
    )
    assert size.goals[0].accepts == {"size": (0.03, 0.03, 0.03)}


def test_a_file_without_attributes_keeps_its_layouts_and_any_block_fills_any_goal() -> None:
    text = block("a", "[0.5, 0.0, 0.02]", "jitter = 0.02") + goal("g", "[0.4, 0.2, 0.02]")
    layout = FileTask(parse_task_file(text)).layout(np.random.default_rng(3))
    rng = np.random.default_rng(3)
    assert layout.bodies[0].attributes == {} and layout.goals[0].accepts == {}
    assert (
        layout.bodies[0].position[:2].tolist()
        == (np.array([0.5, 0.0]) + rng.uniform(-0.02, 0.02, 2)).tolist()
    )
    sim = reset(text)
    scene = put(sim, "a", Vector3(x=0.4, y=0.2, z=0.02))
    assert scene.goal("g").filled
    end = sim.end_event(0.0)
    assert end is not None and end.success and end.goals_wrong_object == 0


def test_swapping_two_towers_is_not_done_before_it_starts_and_succeeds_when_swapped() -> None:
    """Before: any block filled any goal, so this file reported success after 0 steps."""
    sim = reset(SWAP)
    scene = sim.scene(0.0)
    assert scene is not None and not any(g.filled for g in scene.goals)
    assert not any(o.filled for o in scene.objects)
    assert sim.evaluation().wrong_object_goals == {"ga0", "ga1", "gb0", "gb1"}
    # Through a free spot: b's tower to the side, a's tower across, b's into a's place.
    park = {"b1": Vector3(x=0.60, y=0.00, z=0.02), "b0": Vector3(x=0.60, y=0.30, z=0.02)}
    for name in ("b1", "b0"):
        put(sim, name, park[name])
    put(sim, "a1", Vector3(x=0.30, y=0.0, z=0.02))
    put(sim, "a0", Vector3(x=0.45, y=0.20, z=0.02))
    put(sim, "a1", Vector3(x=0.45, y=0.20, z=0.06))
    put(sim, "b0", Vector3(x=0.45, y=-0.20, z=0.02))
    scene = put(sim, "b1", Vector3(x=0.45, y=-0.20, z=0.06))
    assert all(g.filled for g in scene.goals) and all(o.filled for o in scene.objects)
    end = sim.end_event(0.0)
    assert end is not None and end.success and end.goals_filled == 4
    assert end.goals_wrong_object == 0 and end.steps == 7


def test_a_goal_holding_an_object_it_does_not_accept_is_not_filled_and_is_counted() -> None:
    sim = reset(COLOURS, max_steps=2)
    scene = put(sim, "b", Vector3(x=0.60, y=-0.10, z=0.02))  # blue into the red goal
    assert not scene.goal("red_goal").filled and not scene.object("b").filled
    assert sim.evaluation().wrong_object_goals == {"red_goal"}
    scene = put(sim, "r", Vector3(x=0.60, y=0.10, z=0.02))  # red into the blue goal
    end = sim.end_event(0.0)
    assert end is not None and end.success is False
    assert end.goals_filled == 0 and end.goals_wrong_object == 2
    assert "2 goals hold an object it does not accept" in end.reason


def test_every_key_a_goal_lists_must_match() -> None:
    text = COLOURS.replace("weight = 2.0 }", "weight = 3 }").replace(
        'accepts = { colour = "red" }', 'accepts = { colour = "red", label = "nut" }'
    )
    with pytest.raises(
        TaskError,
        match=r'goals\.0: red_goal cannot be filled: it accepts colour "red", label "nut"',
    ):
        parse_task_file(text)


def test_a_list_value_draws_one_per_seed_reproducibly() -> None:
    text = (
        block("a", "[0.4, -0.2, 0.02]", 'attributes = { colour = ["red", "blue", "green"] }')
        + block("b", "[0.4, 0.2, 0.02]", 'attributes = { colour = "red" }')
        + goal("g", "[0.6, 0.0, 0.02]", 'accepts = { colour = "red" }')
    )
    task = FileTask(parse_task_file(text))

    def colours(seed: int) -> list[object]:
        return [b.attributes["colour"] for b in task.layout(np.random.default_rng(seed)).bodies]

    draws = [colours(seed) for seed in range(30)]
    assert draws == [colours(seed) for seed in range(30)]  # the seed decides
    assert {d[0] for d in draws} == {"red", "blue", "green"}  # each value comes up
    assert all(d[1] == "red" for d in draws)


def test_shuffle_permutes_an_attribute_among_the_objects_that_carry_it() -> None:
    objects = "".join(
        block(f"b{i}", f"[0.40, {-0.3 + 0.1 * i:.1f}, 0.02]", f'attributes = {{ colour = "{c}" }}')
        for i, c in enumerate(["red", "red", "blue", "blue"])
    ) + block("plain", "[0.3, 0.3, 0.02]")
    goals = "".join(
        goal(f"g{i}", f"[0.65, {-0.3 + 0.1 * i:.1f}, 0.02]", f'accepts = {{ colour = "{c}" }}')
        for i, c in enumerate(["red", "red", "blue", "blue"])
    )
    task = FileTask(parse_task_file('shuffle = ["colour"]\n' + objects + goals))
    layouts = {seed: task.layout(np.random.default_rng(seed)) for seed in range(20)}
    seen = set()
    for layout in layouts.values():
        colours = [b.attributes.get("colour") for b in layout.bodies]
        assert Counter(colours[:4]) == {"red": 2, "blue": 2} and colours[4] is None
        seen.add(tuple(colours))
    assert len(seen) > 3  # the permutation changes with the seed
    again = task.layout(np.random.default_rng(7))
    assert [b.attributes for b in again.bodies] == [b.attributes for b in layouts[7].bodies]


def test_shuffle_leaves_spares_alone_and_permutes_goals_apart_from_objects() -> None:
    colours = ["red", "red", "blue", "blue"]
    objects = "".join(
        block(f"b{i}", f"[0.40, {-0.3 + 0.1 * i:.1f}, 0.02]", f'attributes = {{ colour = "{c}" }}')
        for i, c in enumerate(colours)
    ) + block("s", "[0.3, 0.3, 0.02]", 'attributes = { colour = "green" }\nspare = true')
    goals = "".join(
        goal(f"g{i}", f"[0.65, {-0.3 + 0.1 * i:.1f}, 0.02]", f'attributes = {{ colour = "{c}" }}')
        for i, c in enumerate(colours)
    )
    task = FileTask(parse_task_file('shuffle = ["colour"]\nsame = ["colour"]\n' + objects + goals))
    seen = set()
    for seed in range(20):
        layout = task.layout(np.random.default_rng(seed))
        assert layout.bodies[-1].attributes == {"colour": "green"}  # the spare keeps its own
        bins = [g.attributes["colour"] for g in layout.goals]
        assert Counter(bins) == {"red": 2, "blue": 2}
        assert all(g.accepts == {"colour": g.attributes["colour"]} for g in layout.goals)  # same
        seen.add((tuple(bins), tuple(b.attributes["colour"] for b in layout.bodies[:4])))
    assert len({bins for bins, _ in seen}) > 2 and len(seen) > len({b for b, _ in seen})


@pytest.mark.parametrize(
    ("text", "named"),
    [
        (SWAP.replace('{ id = "b1" }', '{ id = "a1" }'), "goals.3: gb1 cannot be filled"),
        (
            COLOURS.replace('colour = "blue", weight', 'colour = "red", weight', 1),
            "goals.1: blue_goal",
        ),
        (  # the only red block is a spare: the goals are filled without it
            COLOURS.replace('label = "bolt" }', 'label = "bolt" }\nspare = true').replace(
                goal(
                    "blue_goal", "[0.60, 0.10, 0.02]", 'accepts = { colour = "blue", weight = 2.0 }'
                ),
                "",
            ),
            'goals.0: red_goal cannot be filled: it accepts colour "red", and no object that is '
            "not a spare can be that",
        ),
    ],
    ids=["one object for two goals", "no object of that colour", "only a spare has it"],
)
def test_a_file_whose_goals_its_objects_cannot_fill_is_refused_naming_the_goal(
    text: str, named: str
) -> None:
    with pytest.raises(TaskError) as caught:
        parse_task_file(text)
    assert named in str(caught.value)


def test_a_draw_that_cannot_fill_the_goals_is_drawn_again() -> None:
    text = (
        block("a", "[0.4, -0.2, 0.02]", 'attributes = { colour = ["red", "blue"] }')
        + block("b", "[0.4, 0.2, 0.02]", 'attributes = { colour = ["red", "blue"] }')
        + goal("g0", "[0.6, -0.1, 0.02]", 'accepts = { colour = "red" }')
        + goal("g1", "[0.6, 0.1, 0.02]", 'accepts = { colour = "blue" }')
    )
    task = FileTask(parse_task_file(text))
    for seed in range(20):
        colours = {b.attributes["colour"] for b in task.layout(np.random.default_rng(seed)).bodies}
        assert colours == {"red", "blue"}


def test_accepts_and_shuffle_name_only_attributes_that_objects_carry() -> None:
    with pytest.raises(
        TaskError,
        match=r"goals\.0\.accepts\.colur: no object carries an attribute colur; "
        r"did you mean colour\?",
    ):
        parse_task_file(
            COLOURS.replace('accepts = { colour = "red" }', 'accepts = { colur = "red" }')
        )
    with pytest.raises(TaskError, match=r"shuffle\.0: no object carries an attribute label_x"):
        parse_task_file('shuffle = ["label_x"]\n' + COLOURS.replace('label = "bolt"', "size_x = 1"))
    with pytest.raises(TaskError, match=r"objects\.0\.attributes: .*id: is the object's own field"):
        parse_task_file(COLOURS.replace('label = "bolt"', 'id = "x"'))
    with pytest.raises(TaskError, match=r"goals\.0\.accepts: .*size: give the full extents"):
        parse_task_file(
            COLOURS.replace('accepts = { colour = "red" }', "accepts = { size = 0.04 }")
        )
    with pytest.raises(TaskError, match=r"true and false are not attribute values"):
        parse_task_file(COLOURS.replace('label = "bolt"', "shiny = true"))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (('label = "bolt"', "label = [[1]]"), "objects.0.attributes.label: give text or a number"),
        (('label = "bolt"', 'label = ""'), "objects.0.attributes.label: text values have 1 to 64"),
        (('label = "bolt"', "label = 1e9"), "objects.0.attributes.label: numbers lie within"),
        (('label = "bolt"', "label = []"), "objects.0.attributes.label: a list of values holds"),
        (
            ('accepts = { colour = "red" }', 'accepts = { colour = ["red"] }'),
            "line 15: goals.0.accepts.colour: a list is only for size = [x, y, z]",
        ),
    ],
)
def test_a_bad_attribute_value_gets_one_message_naming_its_line(
    edit: tuple[str, str], message: str
) -> None:
    with pytest.raises(TaskError) as caught:
        parse_task_file(COLOURS.replace(*edit))
    assert message in str(caught.value) and "union" not in str(caught.value)
