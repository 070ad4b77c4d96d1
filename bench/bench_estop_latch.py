"""The emergency-stop latch under restarts: does anything move while a stop is held?

Issue #48's target: stop; then kill -9 every combination of sim, skills and planner, and
separately the whole ``manigraph up``; then a reset plus an ``Action`` from another decider.
**0 robot commands** in every combination, ``--runs`` times each (20); ``resume`` then works
within 2 s.

* Combinations of services: one stack (router, sim, skills, expert planner) on its own port
  and state directory, started by this script; for each run it kills the chosen services with
  SIGKILL, starts them again (what ``up``'s supervisor does, without its give-up after five
  restarts in a row), waits until they are alive, then asks for a reset and publishes one
  Action as a second decider would. Every ``RobotCommand`` and ``JointTrajectoryCommand`` on
  the bus is counted, and so are the answers: the reset's refusal and the Action's final
  ``SkillStatus`` reason.
* The whole ``up``: ``manigraph up`` (no episodes) is started, killed with SIGKILL, and
  started again on the same port and state directory, ``--up-runs`` times; each time the same
  reset and Action are tried once it is up.
* Then ``manigraph resume``: the time until a reset is accepted and a real Action moves the
  robot.

Prints a table and one JSON line. Not a test; ``tests/reliability/test_estop_latch.py`` runs
two of these cases in ``make test``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import BusError, RequestRefused
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    JointTrajectoryCommand,
    RobotCommand,
    Scene,
    SkillStatus,
)
from manigraph_testkit.testing import Stack, free_port, stack

SERVICES = ("sim", "skills", "planner")
STARTUP = 120.0


class Watch:
    """Counts what moves the robot, and keeps every skill status and scene."""

    def __init__(self, bus: Bus) -> None:
        self.commands = 0
        self.statuses: dict[str, SkillStatus] = {}
        self.scenes: dict[str, Scene] = {}
        self._lock = threading.Lock()
        bus.subscribe(RobotCommand, self._moved)
        bus.subscribe(JointTrajectoryCommand, self._moved)
        bus.subscribe(SkillStatus, self._status)
        bus.subscribe(Scene, self._scene)

    def _moved(self, _: object) -> None:
        with self._lock:
            self.commands += 1

    def _status(self, status: SkillStatus) -> None:
        if status.state.terminal:
            with self._lock:
                self.statuses[status.decision_id] = status

    def _scene(self, scene: Scene) -> None:
        with self._lock:
            self.scenes[scene.episode_id] = scene

    def final(self, decision_id: str, timeout: float = 10.0) -> SkillStatus | None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if decision_id in self.statuses:
                    return self.statuses[decision_id]
            time.sleep(0.02)
        return None

    def scene(self, episode_id: str, timeout: float = 10.0) -> Scene | None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if episode_id in self.scenes:
                    return self.scenes[episode_id]
            time.sleep(0.02)
        return None


def attempt(bus: Bus, watch: Watch, tag: str) -> tuple[str, str, int]:
    """A reset and one Action from a second decider; (reset answer, Action's fate, commands)."""
    before = watch.commands
    episode = f"latch-{tag}"
    try:
        bus.request(
            EpisodeRequest(episode_id=episode, task="stack", blocks=3, seed=0),
            EpisodeEvent,
            timeout=20.0,
        )
        reset = "ACCEPTED"
    except RequestRefused as exc:
        text = str(exc)
        reset = "refused estop_engaged" if "estop_engaged" in text else f"refused: {text[:80]}"
    except BusError as exc:
        reset = f"no answer: {exc}"[:80]
    decision = f"{episode}:other-decider"
    bus.publish(
        Action(
            decision_id=decision,
            episode_id=episode,
            scene_sequence=1,
            object_id="block_2",
            goal_id="goal_0",
            policy="other-decider",
            stamp=time.time(),
        )
    )
    final = watch.final(decision)
    fate = f"{final.state} {final.reason}" if final is not None else "no status"
    time.sleep(0.5)  # a command it caused would be on the bus by now
    return reset, fate, watch.commands - before


def kill_and_restart(running: Stack, bus: Bus, names: tuple[str, ...]) -> None:
    for name in names:
        running.stop(name, signal.SIGKILL)
    deadline = time.monotonic() + 10.0
    while set(names) & bus.alive_services(timeout=0.5) and time.monotonic() < deadline:
        time.sleep(0.05)
    for name in names:
        args = ["--policy", "expert"] if name == "planner" else []
        running.start(name, name, *args)
    running.wait_alive(bus, *names, timeout=STARTUP)


def services_case(
    runs: int, log_dir: Path, only: set[str] | None = None
) -> tuple[dict[str, dict[str, object]], Stack]:
    rows: dict[str, dict[str, object]] = {}
    with stack(log_dir) as running:
        running.start("router")
        for name in SERVICES:
            running.start(name, name, *(["--policy", "expert"] if name == "planner" else []))
        with running.client() as bus:
            watch = Watch(bus)
            running.wait_alive(bus, *SERVICES, timeout=STARTUP)
            stop = running.run("stop", "--reason", "bench latch", timeout=60)
            if stop.returncode != 0:
                raise SystemExit(f"manigraph stop failed: {stop.stderr}")
            combos = [
                c for k in range(1, len(SERVICES) + 1) for c in itertools.combinations(SERVICES, k)
            ]
            for combo in combos:
                name = "+".join(combo)
                if only is not None and name not in only:
                    continue
                resets: Counter[str] = Counter()
                fates: Counter[str] = Counter()
                commands = 0
                for run in range(runs):
                    kill_and_restart(running, bus, combo)
                    tag = f"{'-'.join(combo)}-{run}"  # an id: no '+'
                    reset, fate, moved = attempt(bus, watch, tag)
                    resets[reset] += 1
                    fates[fate] += 1
                    commands += moved
                rows[name] = {
                    "runs": runs,
                    "robot_commands": commands,
                    "resets": dict(resets),
                    "actions": dict(fates),
                }
                print(f"  kill -9 {name:<22} x{runs}: {commands} robot commands", flush=True)
            rows["resume"] = resume_timing(running, bus, watch)
    return rows, running


def resume_timing(running: Stack, bus: Bus, watch: Watch) -> dict[str, object]:
    """``manigraph resume``, then resets until one is accepted and a real Action moves."""
    started = time.monotonic()
    resumed = running.run("resume", timeout=60)
    command_s = time.monotonic() - started
    accepted_s = None
    for attempt_no in itertools.count():
        try:
            bus.request(
                EpisodeRequest(episode_id=f"resumed-{attempt_no}", task="stack", blocks=3, seed=0),
                EpisodeEvent,
                timeout=5.0,
            )
            accepted_s = time.monotonic() - started
            break
        except (RequestRefused, BusError):
            if time.monotonic() - started > 30:
                break
            time.sleep(0.05)
    moved_s = None
    if accepted_s is not None:
        scene = watch.scene(f"resumed-{attempt_no}")
        if scene is not None:
            block = max(scene.objects, key=lambda o: o.position.z)
            goal = min((g for g in scene.goals if not g.filled), key=lambda g: g.position.z)
            before = watch.commands
            bus.publish(
                Action(
                    decision_id=f"resumed-{attempt_no}:0",
                    episode_id=scene.episode_id,
                    scene_sequence=scene.sequence,
                    object_id=block.id,
                    goal_id=goal.id,
                    policy="bench",
                    stamp=time.time(),
                )
            )
            deadline = time.monotonic() + 10
            while watch.commands == before and time.monotonic() < deadline:
                time.sleep(0.01)
            if watch.commands > before:
                moved_s = time.monotonic() - started
    return {
        "exit": resumed.returncode,
        "command_s": round(command_s, 3),
        "reset_accepted_s": round(accepted_s, 3) if accepted_s is not None else None,
        "robot_moved_s": round(moved_s, 3) if moved_s is not None else None,
    }


def up_case(runs: int, state: Path) -> dict[str, object]:
    port = free_port()
    env = {
        **os.environ,
        "MANIGRAPH_STATE_DIR": str(state),
        "MANIGRAPH_ZENOH_CONNECT": f"tcp/127.0.0.1:{port}",
    }
    cli = [sys.executable, "-m", "manigraph_shared.cli"]

    def start_up() -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            [*cli, "up", "--port", str(port), "--task", "stack", "--blocks", "3"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )

    resets: Counter[str] = Counter()
    fates: Counter[str] = Counter()
    commands = 0
    config = BusConfig(connect=(f"tcp/127.0.0.1:{port}",), wait_seconds=STARTUP)
    up = start_up()
    try:
        with Bus.open(config) as bus:
            wait_for_stack(bus)
            stop = subprocess.run(
                [*cli, "stop", "--port", str(port), "--reason", "bench latch (up)"],
                capture_output=True,
                env=env,
                timeout=60,
            )
            if stop.returncode != 0:
                raise SystemExit(f"manigraph stop failed: {stop.stderr!r}")
        for run in range(runs):
            up.send_signal(signal.SIGKILL)
            up.wait()
            time.sleep(1.0)  # its children follow it (parent-death signal)
            up = start_up()
            with Bus.open(config) as bus:
                watch = Watch(bus)
                wait_for_stack(bus)
                reset, fate, moved = attempt(bus, watch, f"up-{run}")
            resets[reset] += 1
            fates[fate] += 1
            commands += moved
            print(f"  kill -9 up, run {run + 1}/{runs}: {moved} robot commands", flush=True)
    finally:
        os.killpg(up.pid, signal.SIGTERM)
        up.wait(timeout=30)
    return {
        "runs": runs,
        "robot_commands": commands,
        "resets": dict(resets),
        "actions": dict(fates),
    }


def wait_for_stack(bus: Bus) -> None:
    deadline = time.monotonic() + STARTUP
    while not set(SERVICES) <= bus.alive_services(timeout=1.0):
        if time.monotonic() > deadline:
            raise SystemExit("the stack did not come up")
        time.sleep(0.2)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20, help="runs per combination")
    parser.add_argument("--up-runs", type=int, default=20, help="kill -9 of the whole up")
    parser.add_argument(
        "--only", nargs="*", help="these combinations only, e.g. sim+skills (default: every one)"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-latch-") as tmp:
        started = time.monotonic()
        print(f"combinations of {', '.join(SERVICES)}, {args.runs} runs each:", flush=True)
        rows, _ = services_case(args.runs, Path(tmp), set(args.only) if args.only else None)
        if args.up_runs:
            print(f"the whole up, {args.up_runs} runs:", flush=True)
            rows["up"] = up_case(args.up_runs, Path(tmp) / "up-state")
    resume = rows.pop("resume")
    print("\n| killed (SIGKILL) | runs | robot commands | resets | the other decider's Action |")
    print("|---|---|---|---|---|")
    for name, row in rows.items():
        print(
            f"| {name} | {row['runs']} | {row['robot_commands']} | "
            f"{json.dumps(row['resets'])} | {json.dumps(row['actions'])} |"
        )
    print(
        f"\nresume: command {resume['command_s']} s, reset accepted after "
        f"{resume['reset_accepted_s']} s, robot moved after {resume['robot_moved_s']} s"
    )
    total = sum(int(row["robot_commands"]) for row in rows.values())  # type: ignore[call-overload]
    print(
        json.dumps(
            {
                "rows": rows,
                "resume": resume,
                "robot_commands": total,
                "seconds": round(time.monotonic() - started, 1),
                "load": os.getloadavg(),
            }
        )
    )
    return 0 if total == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
