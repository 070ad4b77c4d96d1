"""User task files: validated, documented, and run like the built-in tasks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.tasks.task_file import FileTask, parse_task_file

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
