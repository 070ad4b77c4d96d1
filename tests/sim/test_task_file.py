"""User task files: validated, documented, and run like the built-in tasks."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from manigraph_blocks.sim.task_file import FileTask, parse_task_file
from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "two-towers.toml"

VALID = """
[[objects]]
id = "a"
category = "block"
position = [0.5, 0.0, 0.02]

[[goals]]
id = "g"
category = "block"
position = [0.4, 0.2, 0.02]

[[goals]]
id = "spare"
category = "cover"
position = [0.6, 0.2, 0.005]
optional = true
"""


def test_the_shipped_example_is_solved_by_the_expert() -> None:
    text = EXAMPLE.read_text()
    summary = evaluate(
        load_policy("expert"), EvalSpec("file", 3, episodes=3, task_file=text), progress=None
    )
    assert summary["success_rate"] == 1.0 and summary["mean_steps"] == 3.0


def test_optional_goals_are_not_required_and_layout_is_seeded() -> None:
    spec = parse_task_file(VALID.replace("[[objects]]", "randomize_xy = 0.1\n[[objects]]", 1))
    a = FileTask(spec).layout(np.random.default_rng(1))
    b = FileTask(spec).layout(np.random.default_rng(1))
    c = FileTask(spec).layout(np.random.default_rng(2))
    assert a.required_goals() == {"g"}
    assert a.bodies[0].position.tolist() == b.bodies[0].position.tolist()
    assert a.bodies[0].position.tolist() != c.bodies[0].position.tolist()


def test_the_sim_backend_runs_a_task_file_request() -> None:
    sim = GeometricBackend()
    start = sim.reset(EpisodeRequest(episode_id="f", task="file", task_file=VALID), 0.0)
    assert start.goals_total == 1
    scene = sim.scene(0.0)
    assert scene is not None and {o.id for o in scene.objects} == {"a"}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('name = "unterminated\n', "line 1"),
        (VALID.replace('category = "block"', 'category = "ball"', 1), "objects.0.category"),
        (VALID.replace("[0.4, 0.2, 0.02]", "[0.4, 0.2]"), "goals.0.position.2"),
        (VALID.replace("[0.5, 0.0, 0.02]", "[0.5, 0.0, nan]"), "objects.0.position.2"),
        (VALID.replace('id = "g"', 'id = "a"'), "id: used twice: a"),
        (VALID + "\ncolour = 3\n", "colour"),
        (
            VALID.replace("optional = true", "optional = true").replace(
                '[[goals]]\nid = "g"\ncategory = "block"\nposition = [0.4, 0.2, 0.02]\n', ""
            ),
            "at least one goal must not be optional",
        ),
    ],
)
def test_bad_files_name_the_line_or_field(text: str, message: str) -> None:
    with pytest.raises(TaskError, match="task file") as caught:
        parse_task_file(text)
    assert message in str(caught.value)


def test_file_task_without_its_text_is_refused() -> None:
    with pytest.raises(TaskError, match="task_file"):
        GeometricBackend().reset(EpisodeRequest(episode_id="f", task="file"), 0.0)


SPARES = Path(__file__).resolve().parents[2] / "examples" / "spares-and-jitter.toml"


def test_one_file_describes_a_distribution_of_scenes_seeded_by_the_episode() -> None:
    task = FileTask(parse_task_file(SPARES.read_text()))
    draws = [task.layout(np.random.default_rng(seed)) for seed in (1, 1, 2, 3, 4)]
    where = [{b.id: b.position.round(4).tolist() for b in d.bodies} for d in draws]
    assert where[0] == where[1]  # the same seed, the same scene
    assert len({str(w) for w in where}) == 4  # other seeds, other scenes
    for w in where:
        base, top = w["tower_base"], w["tower_top"]
        assert base[:2] == top[:2] and top[2] > base[2]  # the tower moves as one
        assert w["spare_a"] != w["spare_b"]  # never both on one listed position
        listed = [[0.35, 0.0, 0.02], [0.4, -0.1, 0.02], [0.65, 0.1, 0.02]]
        assert w["spare_a"] in listed and w["spare_b"] in listed
        assert abs(w["loose"][0] - 0.60) <= 0.03 and abs(w["loose"][1] + 0.05) <= 0.03
    for d in draws:
        d.validate()


def test_spares_belong_to_no_goal_and_the_expert_fills_every_goal_anyway() -> None:
    text = SPARES.read_text()
    spec = parse_task_file(text)
    assert spec.blocks == 5 and sum(o.spare for o in spec.objects) == 2
    summary = evaluate(
        load_policy("expert"),
        EvalSpec("file", 5, episodes=3, task_file=text, task_file_name="spares-and-jitter"),
        progress=None,
    )
    assert summary["success_rate"] == 1.0 and summary["task_file"] == "spares-and-jitter"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda t: t.replace(
                "position = [0.60, -0.05, 0.02]",
                "position = [0.60, -0.05, 0.02]\npositions = [[0.6, 0.0, 0.02]]",
            ),
            "line 20: objects.2.position: give either position or positions",
        ),
        (
            lambda t: t.replace(
                'id = "loose"\ncategory = "block"', 'id = "loose"\ncategory = "block"\nspare = true'
            ),
            "goals: 3 required block goals but only 2 blocks in objects that are not spares",
        ),
        (
            lambda t: t.replace(
                "position = [0.45, -0.20, 0.06]", "position = [0.45, -0.20, 0.06]\njitter = 0.01"
            ),
            "objects.1: rests on tower_base and moves with it",
        ),
        (lambda t: t.replace("jitter = 0.03", "jitter = -1"), "objects.2.jitter"),
    ],
)
def test_bad_randomizations_and_spares_name_the_field(
    edit: Callable[[str], str], message: str
) -> None:
    with pytest.raises(TaskError, match=re.escape(message)):
        parse_task_file(edit(SPARES.read_text()))


def test_a_draw_that_cannot_keep_objects_apart_is_refused_naming_the_object() -> None:
    text = SPARES.read_text().replace(
        "[0.35, 0.00, 0.02], [0.40, -0.10, 0.02], [0.65, 0.10, 0.02]", "[0.35, 0.00, 0.02]"
    )
    with pytest.raises(TaskError, match=r"objects\.4\.positions: every listed position is taken"):
        FileTask(parse_task_file(text)).layout(np.random.default_rng(0))


TWO_BLOCKS = """
randomize_xy = {shift}

[[objects]]
id = "red"
category = "block"
position = [0.50, 0.00, 0.02]

[[objects]]
id = "green"
category = "block"
position = {green}

[[goals]]
id = "base"
category = "block"
position = [0.45, 0.20, 0.02]

[[goals]]
id = "top"
category = "block"
position = {top}
"""


def _layout(green: str = "[0.50, 0.00, 0.06]", top: str = "[0.45, 0.20, 0.06]", shift=0.0):
    return TWO_BLOCKS.format(green=green, top=top, shift=shift)


def test_a_possible_layout_with_touching_blocks_is_accepted() -> None:
    spec = parse_task_file(_layout())  # green stands on red: faces touch, nothing overlaps
    assert [o.id for o in spec.objects] == ["red", "green"]


@pytest.mark.parametrize(
    ("text", "named"),
    [
        # green sunk 2 cm into red
        (_layout(green="[0.50, 0.00, 0.04]"), "objects.1: green overlaps objects.0 (red) by 2.0"),
        # a goal 5 m away (inside the file format's bounds, outside the robot's reach)
        (_layout(top="[4.5, 0.20, 0.06]"), "goals.1.position.0: top at 4.5 m is outside"),
        # a goal that the seeded shift can push out of reach
        (_layout(top="[0.85, 0.20, 0.06]", shift=0.1), "goals.1.position.0: top"),
        (_layout(green="[0.3, 0.0, -0.5]"), "objects.1.position.2: green reaches"),
        (_layout(top="[0.46, 0.21, 0.03]"), "goals.1: top is 1.0 cm from goals.0 (base)"),
        (
            _layout()
            + '\n[[goals]]\nid = "third"\ncategory = "block"\nposition = [0.3, 0.3, 0.02]\n',
            "goals: 3 required block goals but only 2 blocks",
        ),
        (
            _layout()
            + '\n[[goals]]\nid = "lid"\ncategory = "cover"\nposition = [0.3, 0.3, 0.01]\n',
            "goals: 1 required cover goals but only 0 covers",
        ),
    ],
)
def test_layouts_that_cannot_happen_are_refused_naming_the_object(text: str, named: str) -> None:
    with pytest.raises(TaskError, match="task file") as caught:
        parse_task_file(text)
    assert named in str(caught.value)


def test_an_impossible_layout_is_refused_by_the_sim_reset() -> None:
    request = EpisodeRequest(
        episode_id="f", task="file", task_file=_layout(green="[0.50, 0.00, 0.04]")
    )
    with pytest.raises(TaskError, match="green overlaps"):
        GeometricBackend().reset(request, 0.0)


def test_a_file_with_thousands_of_problems_names_ten_and_counts_the_rest() -> None:
    blocks = "".join(
        f'[[objects]]\nid = "b{i}"\ncategory = "block"\nposition = [0.5, 0.0, 0.02]\n'
        for i in range(20)
    )
    text = blocks + '[[goals]]\nid = "g"\ncategory = "block"\nposition = [0.4, 0.2, 0.02]\n'
    with pytest.raises(TaskError) as caught:
        parse_task_file(text)
    message = str(caught.value)
    assert message.count("overlaps") == 10 and message.endswith("and 180 more")
