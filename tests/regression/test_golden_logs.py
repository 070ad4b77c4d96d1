"""Shipped policies must keep deciding what they decided in the committed golden logs.

Regenerate with scripts/regenerate-golden-logs.sh only when a change of decisions is intended.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_planner.policies import load_policy
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene
from manigraph_testkit.testing import Stack

REPO = Path(__file__).resolve().parents[2]
GOLDEN = sorted((REPO / "tests" / "golden").glob("*.mcap"))


def checkpoint_of(log: Path) -> Path:
    return REPO / "checkpoints" / f"{log.stem.split('-')[0]}.pt"


def test_every_shipped_checkpoint_has_golden_logs() -> None:
    # The dishwasher checkpoints are checked by tests/planner/gnn/test_dish_policy.py.
    shipped = {
        p.stem for p in (REPO / "checkpoints").glob("*.pt") if not p.stem.startswith("dishwasher-")
    }
    assert shipped == {"gcn", "sage", "gated", "gat"}
    assert {log.stem.split("-")[0] for log in GOLDEN} == shipped


@pytest.mark.parametrize("log", GOLDEN, ids=lambda p: p.stem)
def test_policy_takes_the_recorded_decision_on_every_recorded_scene(log: Path) -> None:
    scenes = {}
    for item in read_log(log, [Scene.key]):
        scene = Scene.decode(item.data)
        scenes[(scene.episode_id, scene.sequence)] = scene
    actions = [Action.decode(item.data) for item in read_log(log, [Action.key])]
    assert actions, f"{log.name} holds no decisions"
    policy = load_policy(str(checkpoint_of(log)))
    for action in actions:
        key = (action.episode_id, action.scene_sequence)
        assert key in scenes, (
            f"{log.name} lacks scene {action.scene_sequence}, decided on in "
            f"{action.decision_id}: scenes are sent 'latest only' and the recorder missed it; "
            "regenerate the log (scripts/regenerate-golden-logs.sh) on a quiet machine"
        )
        decision = policy.decide(scenes[key])
        assert decision is not None
        assert (decision.object_id, decision.goal_id) == (action.object_id, action.goal_id), (
            f"{log.name} {action.decision_id}"
        )


@pytest.mark.integration
def test_golden_log_replayed_over_zenoh_drives_a_fresh_planner_identically(
    running_stack: Stack,
) -> None:
    log = REPO / "tests" / "golden" / "sage-pyramid6.mcap"
    running_stack.start("router")
    running_stack.start("planner", "planner", "--policy", str(checkpoint_of(log)))
    result = running_stack.run("replay", str(log), "--expect-actions", "--speed", "4")
    assert result.returncode == 0, result.stderr[-2000:]
    assert json.loads(result.stdout.strip().splitlines()[-1])["identical"] is True
