"""A block let go of in a colour-sort bin stays on its goal.

The bins' goals stand 2 cm from a wall, which the skills do not see. Far out (colour sort
anywhere, seed 52132: goals at x = 0.69 m), the fingers opening fully jammed against the
wall and the hand rising dragged the block 1.7 cm off its goal, towards the wall (with no
bins, or at x = 0.62 m, it stayed). The sim still called it placed (2 cm); the RGB-D
camera's pose, a few millimetres off again, did not (``placement_missed``, or a goal filled
for perception and empty for the sim: ``no_progress``). The fingers now let a block go 2 cm
wider than it (``grasp_choice.release_opening``)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from manigraph_shared.messages import EpisodeRequest, SkillState

Loop = Any  # tests/physics/conftest.py: InProcessLoop
ANYWHERE = Path(__file__).resolve().parents[2] / "examples/tasks/colour-sort-anywhere.toml"


def test_a_block_let_go_of_beside_a_bin_wall_stays_on_its_goal(loop: Loop) -> None:
    request = EpisodeRequest(
        episode_id="bins", task="file", task_file=ANYWHERE.read_text(), blocks=4, seed=52132
    )
    loop.backend.reset(request, time.time())
    scene = loop.scene()
    goals = {"red": "red_goal_0", "blue": "blue_goal_0"}
    moved = []
    for item in scene.objects:
        goal_id = goals.pop(str(item.attributes["colour"]), None)
        if goal_id is None:
            continue
        assert loop.move(item.id, goal_id).state is SkillState.SUCCEEDED
        moved.append((item.id, goal_id))
    scene = loop.scene()
    for object_id, goal_id in moved:
        at = np.array(scene.object(object_id).position.as_tuple())
        goal = np.array(scene.goal(goal_id).position.as_tuple())
        assert np.linalg.norm(at[:2] - goal[:2]) < 0.006, (object_id, at, goal)
