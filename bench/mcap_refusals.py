"""Refusals in a recorded run (``manigraph up --episodes N --record run.mcap``), per episode.

For every decision the skills refused (its ``SkillStatus`` failed), with the Scene the planner
decided on (``Action.scene_sequence``):

* ``refusals``: by reason (``{reason: count}``), transient ones too;
* ``refused_again_unchanged``: refusals of a pair (object, goal) refused before in the same
  episode for the same reason, the world the same when the two were decided (every object
  within 5 mm, the same goals filled: ``ProgressMonitor.same_world``, as
  bench/bench_recovery.py counts it) and the racks where they were. Retried reasons
  (``grasp_slipped``, ``placement_missed``: asked again on purpose) and transient ones are
  counted apart (``retried_again``). Target: 0 (issue 51);
* ``recovered``: actions the planner marked ``recovery = "refused"`` (a refusal passed over).

    python bench/mcap_refusals.py run.mcap [--json]
"""

from __future__ import annotations

import argparse
import json
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from manigraph_planner.recovery import RETRYABLE, ProgressMonitor
from manigraph_planner.refusals import scope_of
from manigraph_shared.mcap_log import decode_log
from manigraph_shared.messages import Action, Scene, SkillState, SkillStatus


@dataclass
class Refused:
    decision_id: str
    pair: tuple[str, str]
    reason: str
    scene: Scene | None


@dataclass
class EpisodeRefusals:
    refusals: Counter[str] = field(default_factory=Counter)
    refused_again_unchanged: list[str] = field(default_factory=list)
    retried_again: int = 0
    passed_over: int = 0
    actions: int = 0


def fixtures(scene: Scene) -> tuple[tuple[str, tuple[tuple[str, object], ...]], ...]:
    """Each fixture's state (a rack's travel to the centimetre)."""
    return tuple(
        (
            f.id,
            tuple(
                sorted((k, round(v, 2) if isinstance(v, float) else v) for k, v in f.state.items())
            ),
        )
        for f in sorted(scene.fixtures, key=lambda f: f.id)
    )


def unchanged(monitor: ProgressMonitor, a: Scene | None, b: Scene | None) -> bool:
    if a is None or b is None:
        return False
    return monitor.same_world(a, b) and fixtures(a) == fixtures(b)


def analyse(path: Path) -> dict[str, EpisodeRefusals]:
    scenes: dict[tuple[str, int], Scene] = {}
    actions: dict[str, Action] = {}
    failed: list[SkillStatus] = []
    for message in decode_log(
        path, ["manigraph/**/scene", "manigraph/**/action", "manigraph/**/status"]
    ):
        if isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = message
        elif isinstance(message, Action):
            actions[message.decision_id] = message
        elif isinstance(message, SkillStatus) and message.state is SkillState.FAILED:
            failed.append(message)
    episodes: dict[str, EpisodeRefusals] = defaultdict(EpisodeRefusals)
    for action in actions.values():
        episode = episodes[action.episode_id]
        episode.actions += 1
        if action.recovery == "refused":
            episode.passed_over += 1
    monitor = ProgressMonitor()
    seen: dict[str, list[Refused]] = defaultdict(list)
    for status in failed:
        action = actions.get(status.decision_id)
        if action is None:
            continue
        reason = status.reason or "unknown"
        episode = episodes[action.episode_id]
        episode.refusals[reason] += 1
        now = Refused(
            status.decision_id,
            (action.object_id, action.goal_id),
            reason,
            scenes.get((action.episode_id, action.scene_sequence)),
        )
        earlier = [
            r
            for r in seen[action.episode_id]
            if r.pair == now.pair and r.reason == reason and unchanged(monitor, r.scene, now.scene)
        ]
        if earlier:
            if reason in RETRYABLE or scope_of(reason) == "transient":
                episode.retried_again += 1
            else:
                episode.refused_again_unchanged.append(
                    f"{now.decision_id} {now.pair[0]}->{now.pair[1]}: {reason}"
                )
        seen[action.episode_id].append(now)
    return dict(episodes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mcap", type=Path)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    episodes = analyse(args.mcap)
    total: Counter[str] = Counter()
    again: list[str] = []
    for episode_id, e in sorted(episodes.items()):
        total.update(e.refusals)
        again += e.refused_again_unchanged
        print(
            f"{episode_id}: {e.actions} actions, refusals {dict(e.refusals)}, "
            f"refused again unchanged {len(e.refused_again_unchanged)}, "
            f"retried again {e.retried_again}, passed over {e.passed_over}"
        )
    for line in again:
        print(f"  again: {line}")
    summary = {
        "episodes": len(episodes),
        "refusals": dict(total.most_common()),
        "refused_again_unchanged": len(again),
        "retried_again": sum(e.retried_again for e in episodes.values()),
        "passed_over": sum(e.passed_over for e in episodes.values()),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
