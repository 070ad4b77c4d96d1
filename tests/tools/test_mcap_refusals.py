"""bench/mcap_refusals.py: a pair refused twice for the same reason on an unchanged scene is
counted from a recorded run; a moved object, a retried reason or another reason are not."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import (
    Action,
    Scene,
    SceneGoal,
    SceneObject,
    SkillStatus,
    Vector3,
)

ROOT = Path(__file__).resolve().parents[2]
B = 0.04


def _bench():
    spec = importlib.util.spec_from_file_location("mcap_refusals", ROOT / "bench/mcap_refusals.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["mcap_refusals"] = module
    spec.loader.exec_module(module)
    return module


def scene(seq: int, a_x: float) -> Scene:
    size = Vector3(x=B, y=B, z=B)
    objects = [
        SceneObject(id=name, category="block", position=Vector3(x=x, y=0.0, z=B / 2), size=size)
        for name, x in (("a", a_x), ("b", 0.7))
    ]
    goal = SceneGoal(id="g0", category="block", position=Vector3(x=0.3, y=0.0, z=B / 2))
    return Scene(episode_id="e", stamp=float(seq), sequence=seq, objects=objects, goals=[goal])


def write_run(path: Path, steps: list[tuple[float, str, str]]) -> None:
    """One decision per step on a scene with ``a`` at x, refused for the reason given."""
    log = McapLogWriter(path)
    for step, (a_x, picked, reason) in enumerate(steps, start=1):
        t = step * 1_000_000_000
        log.write(Scene.key, scene(step, a_x).encode(), t)
        action = Action(
            decision_id=f"e:{step}",
            episode_id="e",
            scene_sequence=step,
            object_id=picked,
            goal_id="g0",
            policy="p",
            stamp=float(step),
        )
        log.write(Action.key, action.encode(), t + 1)
        status = SkillStatus(
            decision_id=action.decision_id, skill="p", state="failed", reason=reason, stamp=step
        )
        log.write(SkillStatus.key, status.encode(), t + 2)
    log.close()


def test_only_a_repeat_on_an_unchanged_scene_for_the_same_reason_counts(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    write_run(
        path,
        [
            (0.5, "a", "no_ik_solution"),
            (0.5, "a", "no_ik_solution"),  # the same world, the same reason: counted
            (0.5, "a", "collision"),  # another reason
            (0.6, "a", "no_ik_solution"),  # a moved
            (0.6, "b", "grasp_slipped"),
            (0.6, "b", "grasp_slipped"),  # retried on purpose: apart
        ],
    )
    episode = _bench().analyse(path)["e"]
    assert episode.refused_again_unchanged == ["e:2 a->g0: no_ik_solution"]
    assert episode.retried_again == 1
    assert episode.refusals == {"no_ik_solution": 3, "collision": 1, "grasp_slipped": 2}
