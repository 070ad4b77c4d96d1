"""Rules only the teacher and the judge know (docs/task-files.md): a rules file is checked
against its task file, naming lines; the judge decides success, wrong objects and rule
violations by it; the Scene and the TaskLayout stay the task file's."""

from __future__ import annotations

import pytest

from manigraph_blocks.sim.rules_file import parse_rules_file
from manigraph_shared.errors import ConfigError, DrawRefused, TaskError
from manigraph_shared.messages import EpisodeRequest, GripperOp, RobotCommand, Vector3
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.layout_message import layout_message
from manigraph_sim.tasks.from_request import episode_layout

#: Two blocks, two bins; the file says nothing of which goes where.
TASK = """
name = "two bins"

[[objects]]
id = "a"
category = "block"
position = [0.40, -0.10, 0.02]
attributes = { colour = "red" }

[[objects]]
id = "b"
category = "block"
position = [0.40, 0.10, 0.02]
attributes = { colour = "blue" }

[[goals]]
id = "left"
category = "block"
position = [0.62, 0.10, 0.02]
attributes = { colour = "red" }

[[goals]]
id = "right"
category = "block"
position = [0.62, -0.10, 0.02]
attributes = { colour = "blue" }
"""
RULES = '[[goals]]\nid = "left"\naccepts = { colour = "red" }\n'


def request(rules: str | None = RULES, task: str = TASK) -> EpisodeRequest:
    return EpisodeRequest(episode_id="e", task="file", task_file=task, rules=rules)


def place(sim: GeometricBackend, obj: str, goal: tuple[float, float, float]) -> None:
    """Pick ``obj`` and release it above ``goal`` (the geometric world's magic gripper)."""
    for op in (GripperOp.PICK, GripperOp.PLACE):
        where = Vector3(x=goal[0], y=goal[1], z=goal[2])
        command = RobotCommand(
            command_id=f"{obj}-{op}",
            decision_id="d",
            op=op,
            object_id=obj,
            position=where,
            stamp=0.0,
        )
        assert sim.execute(command, 0.0).ok


def test_the_scene_and_layout_are_the_task_files_with_or_without_rules() -> None:
    ruled, plain = episode_layout(request()), episode_layout(request(None))
    assert layout_message(ruled.layout, "e", 0) == layout_message(plain.layout, "e", 0)
    goal = layout_message(ruled.layout, "e", 0).goals[0]
    assert goal.accepts == {} and goal.attributes == {"colour": "red"}
    assert ruled.layout.judge is not None and plain.layout.judge is None


def test_the_judge_counts_a_placement_the_rules_refuse_even_when_undone() -> None:
    sim = GeometricBackend()
    sim.reset(request(), 0)
    place(sim, "b", (0.62, 0.10, 0.02))  # blue into the left bin: the rules refuse it
    scene = sim.scene(0)
    assert scene is not None and scene.goal("left").filled  # the Scene: the file's rule
    place(sim, "b", (0.40, 0.30, 0.02))  # taken back out
    place(sim, "a", (0.62, 0.10, 0.02))
    place(sim, "b", (0.62, -0.10, 0.02))
    end = sim.end_event(0)
    assert end is not None and end.success and end.rule_violations == 1


def test_same_makes_each_goal_take_its_own_colour() -> None:
    sim = GeometricBackend()
    sim.reset(request('same = ["colour"]\n'), 0)
    place(sim, "a", (0.62, -0.10, 0.02))  # red into the blue bin
    place(sim, "b", (0.62, 0.10, 0.02))
    sim.ended = True
    end = sim.end_event(0)
    assert end is not None and not end.success
    assert end.rule_violations == 2 and end.goals_wrong_object == 2


@pytest.mark.parametrize(
    ("rules", "error"),
    [
        (
            '\n[[goals]]\nid = "lefft"\n',
            r"line 3: goals\.0\.id: the task file has no goal lefft; "
            "did you mean left\\?",
        ),
        (
            '[[goals]]\nid = "left"\naccepts = { color = "red" }\n',
            r"line 3: goals\.0\.accepts\.color: no object carries an attribute color; did you mean",
        ),
        ('same = ["shape"]\n', r"line 1: same\.0: no goal of the task file carries"),
        (
            '[[goals]]\nid = "left"\naccepts = { colour = "green" }\n',
            r"goals\.0: left cannot be filled: it accepts colour \"green\"",
        ),
        ('[[goals]]\nid = "left"\npriority = 2\n', r"line 3: goals\.0\.priority"),
    ],
)
def test_a_bad_rules_file_is_refused_naming_its_line(rules: str, error: str) -> None:
    with pytest.raises(TaskError, match=rf"^rules file x\.toml: {error}"):
        parse_rules_file(rules, TASK, "x.toml")


def test_rules_need_a_task_file() -> None:
    with pytest.raises(ConfigError, match=r"^rules: "):
        episode_layout(EpisodeRequest(episode_id="e", task="stack", rules=RULES))


def test_a_seed_the_rules_cannot_fill_is_refused_naming_the_goal() -> None:
    task = TASK.replace(
        'attributes = { colour = "blue" }\n\n[[goals]]',
        'attributes = { colour = ["red", "blue"] }\n\n[[goals]]',
        1,
    )
    rules = '[[goals]]\nid = "right"\naccepts = { colour = "blue" }\n'
    refused = []
    for seed in range(8):
        try:
            episode_layout(request(rules, task).replace(seed=seed))
        except DrawRefused as exc:
            refused.append(seed)
            assert "right cannot be filled" in str(exc) and DrawRefused.MARK in str(exc)
    assert 0 < len(refused) < 8  # b draws red on some seeds, blue on others
