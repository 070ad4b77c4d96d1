"""What a refusal costs: a reset query the sim refuses, and Actions forged for unknown episodes.

1. ``reset_refused_ms``: a client's query on the reset key with a request the sim refuses
   (an unknown task, a task file that is not TOML), from ``get`` to the end of the query (the
   iteration over its replies ends), not only to the error reply. Target: <= 50 ms (issue 45
   item 11); before the fix the query ended only at its timeout.
2. ``forged_delay_s``: between episodes (after a one-block episode's end), ``--forged``
   Actions (default 200) for episodes that never start are published, then a real episode is
   reset and its first action published as a planner would (again every 50 ms while refused
   ``skills_busy``). The time from the reset's reply to skills accepting the real action,
   minus the same without forged actions. Target: <= 0.2 s; it was ~3.5 s.

Router, geometric sim and skills on a loopback port of their own (no planner).

    .venv/bin/python bench/bench_refusals.py [--runs 5] [--forged 200]

One line per measurement and a JSON summary with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import threading
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    Scene,
    SkillState,
    SkillStatus,
)
from manigraph_testkit.testing import Stack, stack

REFUSED = {
    "unknown task": EpisodeRequest(episode_id="bad-1", task="no_such_task"),
    "bad task file": EpisodeRequest(episode_id="bad-2", task="file", task_file="x = [ not toml"),
}


def refused_reset_ms(bus: Bus, request: EpisodeRequest) -> float:
    started = time.perf_counter()
    replies = list(
        bus.session.get(bus.scoped(EpisodeRequest.key), payload=request.encode(), timeout=30)
    )
    seconds = time.perf_counter() - started
    if not replies or replies[0].err is None:
        raise SystemExit(f"the sim did not refuse {request}")
    return seconds * 1e3


class Watch:
    """Scenes and skill statuses as they arrive."""

    def __init__(self, bus: Bus) -> None:
        self.scenes: dict[str, Scene] = {}
        self.statuses: dict[str, SkillStatus] = {}
        self.changed = threading.Condition()
        bus.subscribe(Scene, self._scene)
        bus.subscribe(SkillStatus, self._status)

    def _scene(self, scene: Scene) -> None:
        with self.changed:
            self.scenes.setdefault(scene.episode_id, scene)
            self.changed.notify_all()

    def _status(self, status: SkillStatus) -> None:
        with self.changed:
            if status.state is SkillState.ACCEPTED or status.state.terminal:
                self.statuses[status.decision_id] = status
            self.changed.notify_all()

    def wait(self, test, timeout: float = 20.0):  # type: ignore[no-untyped-def]
        with self.changed:
            if not self.changed.wait_for(test, timeout):
                raise SystemExit("timed out")
            return test()


def first_action_accepted_s(bus: Bus, watch: Watch, episode: str, forged: int) -> float:
    """Publish ``forged`` actions of ghost episodes, reset ``episode`` (one block: its one
    pick and place ends it, so skills is between episodes again after it) and act on its
    scene; seconds from the reset's reply to skills accepting the action."""
    for index in range(forged):
        bus.publish(
            Action(
                decision_id=f"{episode}-forged-{index}",
                episode_id=f"ghost-{episode}-{index}",
                scene_sequence=0,
                object_id="block_0",
                goal_id="goal_0",
                policy="attacker",
                stamp=time.time(),
            )
        )
    bus.request(EpisodeRequest(episode_id=episode, task="stack", blocks=1), EpisodeEvent, 20.0)
    started = time.monotonic()
    scene = watch.wait(lambda: watch.scenes.get(episode))
    block = max((o for o in scene.objects), key=lambda o: o.position.z)
    goal = next(g for g in scene.goals if not g.filled)
    for attempt in range(200):
        decision = f"{episode}:{attempt}"
        bus.publish(
            Action(
                decision_id=decision,
                episode_id=episode,
                scene_sequence=scene.sequence,
                object_id=block.id,
                goal_id=goal.id,
                policy="bench",
                stamp=time.time(),
            )
        )
        status = watch.wait(lambda d=decision: watch.statuses.get(d))
        if status.state is SkillState.ACCEPTED or status.reason != "skills_busy":
            return time.monotonic() - started
        time.sleep(0.05)
    raise SystemExit("never accepted")


def run(running: Stack, runs: int, forged: int) -> dict[str, object]:
    running.start("router")
    running.start("sim", "sim", "--backend", "geometric")
    running.start("skills", "skills")
    with running.client() as bus:
        running.wait_alive(bus, "router", "sim", "skills", timeout=180)
        watch = Watch(bus)
        time.sleep(0.3)
        resets = []
        for index in range(runs):
            for name, request in REFUSED.items():
                ms = refused_reset_ms(bus, request)
                resets.append(ms)
                print(f"refused reset ({name}) {index}: query ended after {ms:.1f} ms", flush=True)
        delays = []
        for index in range(runs):
            base = first_action_accepted_s(bus, watch, f"base-{index}", 0)
            time.sleep(1.5)  # the pick and place ends the episode: skills is between episodes
            flooded = first_action_accepted_s(bus, watch, f"flood-{index}", forged)
            time.sleep(1.5)
            delays.append(flooded - base)
            print(
                f"first action accepted {index}: {base * 1e3:.0f} ms, after {forged} forged "
                f"actions {flooded * 1e3:.0f} ms",
                flush=True,
            )
    return {
        "reset_refused_ms": round(statistics.median(resets), 1),
        "reset_refused_max_ms": round(max(resets), 1),
        "reset_target_ms": 50,
        "forged": forged,
        "forged_delay_s": round(statistics.median(delays), 3),
        "forged_delay_max_s": round(max(delays), 3),
        "forged_target_s": 0.2,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--forged", type=int, default=200)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        summary = run(running, args.runs, args.forged)
    summary["load_average"] = [round(v, 2) for v in os.getloadavg()]
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
