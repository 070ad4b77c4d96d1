"""Forged Actions never cost a real robot command (issue #48 target).

Skills answers every Action it refuses with a failed ``SkillStatus``, and the sim receives
those statuses too. Before the sim kept robot commands in an inbox lane of their own, 2,000
forged Actions filled its inbox of 1,024 and a real ``RobotCommand`` was dropped (3 of 15
episodes stalled 10 s).

A stack (router, geometric sim, expert planner, skills) on its own port runs ``--episodes``
episodes one after another; during each, this client publishes ``--per-episode`` forged
Actions as fast as it can. Every ``RobotCommand`` skills sends and every ``RobotFeedback`` the
sim answers are counted: a command without feedback is lost. Also counted: the sim's own
reports of samples dropped, by lane. Target: 0 real commands lost in 20 episodes with 10,000
forged Actions each. Prints a table and one JSON line. Not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

from manigraph_shared.messages import (
    Action,
    RobotCommand,
    RobotFeedback,
    ServiceStatus,
)
from manigraph_testkit.testing import stack

SERVICES = ("sim", "planner", "skills")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--per-episode", type=int, default=10_000, help="forged Actions")
    parser.add_argument("--blocks", type=int, default=4)
    args = parser.parse_args()
    commands: set[str] = set()
    answered: set[str] = set()
    dropped: Counter[str] = Counter()
    lock = threading.Lock()

    def on_command(command: RobotCommand) -> None:
        with lock:
            commands.add(command.command_id)

    def on_feedback(feedback: RobotFeedback) -> None:
        with lock:
            answered.add(feedback.command_id)

    def on_status(status: ServiceStatus) -> None:
        found = re.search(r"samples dropped \((.*)\)", status.detail)
        if found:
            with lock:
                for part in found.group(1).split(", "):
                    lane, _, count = part.rpartition(" ")
                    if count.isdigit():
                        dropped[lane] = max(dropped[lane], int(count))

    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="bench-flood-") as tmp, stack(Path(tmp)) as running:
        running.start("router")
        for name in SERVICES:
            running.start(name, name, *(["--policy", "expert"] if name == "planner" else []))
        with running.client() as bus:
            bus.subscribe(RobotCommand, on_command)
            bus.subscribe(RobotFeedback, on_feedback)
            bus.subscribe(ServiceStatus, on_status, key="manigraph/status/sim")
            running.wait_alive(bus, *SERVICES, timeout=180)
            results = []
            for episode in range(args.episodes):
                stop = threading.Event()

                def forge(tag: int = episode, stop: threading.Event = stop) -> None:
                    for i in range(args.per_episode):
                        if stop.is_set():
                            return
                        bus.publish(
                            Action(
                                decision_id=f"forged-{tag}:{i}",
                                episode_id=f"forged-{tag}",
                                scene_sequence=i,
                                object_id="block_0",
                                goal_id="goal_0",
                                policy="forger",
                                stamp=time.time(),
                            )
                        )

                forger = threading.Thread(target=forge)
                forger.start()
                run = running.run(
                    "run", "--blocks", str(args.blocks), "--episodes", "1", "--seed",
                    str(5000 + episode), "--json", timeout=600,
                )  # fmt: skip
                forger.join()
                stop.set()
                line = run.stdout.strip().splitlines()[-1] if run.stdout.strip() else "{}"
                summary = json.loads(line) if line.startswith("{") else {}
                result = (summary.get("results") or [{}])[0]
                results.append(result)
                mark = "success" if result.get("success") else f"FAILED {result.get('reason')}"
                print(
                    f"episode {episode + 1}/{args.episodes}: {mark}, {result.get('seconds')} s",
                    flush=True,
                )
            time.sleep(2.0)  # the last feedback and heartbeats
    with lock:
        lost = sorted(commands - answered)
    succeeded = sum(bool(r.get("success")) for r in results)
    print(
        "\n| episodes | forged Actions each | succeeded | robot commands | lost | drops by lane |"
    )
    print("|---|---|---|---|---|---|")
    print(
        f"| {len(results)} | {args.per_episode} | {succeeded} | {len(commands)} | {len(lost)} | "
        f"{dict(dropped) or '-'} |"
    )
    print(
        json.dumps(
            {
                "episodes": len(results),
                "per_episode": args.per_episode,
                "succeeded": succeeded,
                "robot_commands": len(commands),
                "lost": len(lost),
                "dropped_by_lane": dict(dropped),
                "seconds": round(time.monotonic() - started, 1),
                "load": os.getloadavg(),
            }
        )
    )
    return 0 if not lost and "robot" not in dropped else 1


if __name__ == "__main__":
    sys.exit(main())
