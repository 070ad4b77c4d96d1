"""A stack whose planner cannot read the task's scenes says so once and stops the run: the
planner logs it once, the episode ends ``cannot_decide`` at once (not ``no_progress`` after the
stall timeout, with 10 errors a second meanwhile), and ``up`` exits 78 naming it.

(An unseen *word* is read as "other" since issue #49; a number where the policy learned words
is still a scene it cannot read.)"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_planner.gnn.checkpoint import save_checkpoint
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_testkit.testing import run_up

pytestmark = pytest.mark.integration

#: Two blocks whose colour is a number, where the checkpoint learned colours as words.
MAUVE = """
name = "mauve pair"

[[objects]]
id = "b0"
category = "block"
position = [0.45, -0.2, 0.02]
attributes = { colour = 7 }

[[objects]]
id = "b1"
category = "block"
position = [0.45, -0.1, 0.02]
attributes = { colour = 7 }

[[goals]]
id = "g0"
category = "block"
position = [0.5, 0.15, 0.02]

[[goals]]
id = "g1"
category = "block"
position = [0.5, 0.25, 0.02]
"""


def colour_checkpoint(path: Path) -> Path:
    """An untrained policy whose features know the colours blue and red only."""

    def block(name: str, colour: str) -> SceneObject:
        return SceneObject(
            id=name,
            category="block",
            position=Vector3(x=0.4, y=0.0, z=0.02),
            size=Vector3(x=0.04, y=0.04, z=0.04),
            attributes={"colour": colour},
        )

    goal = SceneGoal(id="g", category="block", position=Vector3(x=0.3, y=0.0, z=0.02))
    seen = Scene(
        episode_id="t",
        stamp=1.0,
        sequence=0,
        objects=[block("b0", "red"), block("b1", "blue")],
        goals=[goal],
    )
    net = PolicyNet(ModelConfig("sage", features=FeatureSpec.for_task(TaskFeatures.learn([seen]))))
    return save_checkpoint(path, net, training_config={}, data_hash="h")


def test_an_unreadable_colour_ends_the_run_once_and_up_exits_78(tmp_path: Path) -> None:
    checkpoint = colour_checkpoint(tmp_path / "colours.pt")
    task = tmp_path / "mauve.toml"
    task.write_text(MAUVE)
    logs = tmp_path / "logs"
    result = run_up(
        "--policy", str(checkpoint), "--task-file", str(task), "--episodes", "3",
        "--log-dir", str(logs), "--json",
        check=False,
    )  # fmt: skip
    assert result.returncode == CONFIG_EXIT_CODE, result.stderr[-3000:]
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("manigraph up: cannot_decide: scene: "), result.stderr[-3000:]
    assert "colour 7.0 is a number; this policy knows words" in last
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["episodes"] == 1  # the run stopped with its first episode
    assert summary["aborted"].startswith("cannot_decide: ")
    planner = (logs / "planner.log").read_text()
    assert planner.count("cannot_decide") == 1, planner  # once, not 10 a second
