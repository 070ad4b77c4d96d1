"""Emergency-stop latency: from publishing ``EmergencyStop`` to the skill reporting ``stopped``.

A real router, the physics sim (in real time, so a PickAndPlace lasts long enough to be
interrupted) and the skills service with the Panda driver run as processes on loopback. For
each sample this client resets a 3-block stack, sends one legal Action, waits until the skill
is running plus a random delay (so the stop lands while the arm is planning or moving), then
publishes the stop and times the arrival of the skill's final status, which must be failed
with reason ``stopped``. It also checks that the arm stands still afterwards (joints moving
less than 0.01 rad over 0.3 s), then resumes. Prints the median, p95 and max in
milliseconds, overall and by where the stop landed (a trajectory in flight, or skills
planning between trajectories).
Target: skills stopped within 100 ms of the stop message (p95), max 200 ms, also with the
machine oversubscribed: ``--busy 20`` runs twenty spinning processes (ten per core on two
cores) in this session for the whole run, as planning, training or a browser would. Ends with
one JSON line. Not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from manigraph_shared.bus import Bus
from manigraph_shared.errors import ManigraphError
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    EpisodeEvent,
    EpisodeRequest,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    Scene,
    SkillState,
    SkillStatus,
)
from manigraph_testkit.testing import stack


def legal_first_move(scene: Scene) -> tuple[str, str]:
    block = max(scene.objects, key=lambda o: o.position.z)
    goal = min((g for g in scene.goals if not g.filled), key=lambda g: g.position.z)
    return block.id, goal.id


def warm_up(bus: Bus, attempts: int = 5) -> None:
    """One reset until it succeeds: the physics sim's first one builds its scene, which can
    take longer than the sim's own 30 s answer deadline on a loaded machine."""
    for attempt in range(attempts):
        try:
            bus.request(
                EpisodeRequest(episode_id="estop-warm-up", task="stack", blocks=3, seed=0),
                EpisodeEvent,
                timeout=60.0,
            )
            return
        except ManigraphError as exc:
            print(f"warm-up reset {attempt + 1}: {exc}", flush=True)
    raise SystemExit(f"the sim answered none of {attempts} resets")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log-dir", type=Path, help="keep the services' logs here")
    parser.add_argument("--busy", type=int, default=0, help="spinning processes meanwhile")
    args = parser.parse_args()
    spinners = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)
    ]
    try:
        run(args)
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def run(args: argparse.Namespace) -> None:
    rng = random.Random(args.seed)
    latencies: list[float] = []
    phases: list[str] = []
    at_skills: list[float] = []  # stop sent -> skills stamps its stopped status (one clock)
    halted = 0
    with tempfile.TemporaryDirectory() as logs, stack(args.log_dir or Path(logs)) as running:
        running.start("router")
        running.start("sim", "sim", "--backend", "physics", "--realtime")
        running.start("skills", "skills", "--driver", "panda-sim")
        with running.client(wait_seconds=600) as bus:  # a loaded machine starts slowly
            running.wait_alive(bus, "sim", "skills", timeout=600)
            scenes: queue.SimpleQueue[Scene] = queue.SimpleQueue()
            statuses: queue.SimpleQueue[tuple[float, SkillStatus]] = queue.SimpleQueue()
            joints: list[JointState] = []
            in_flight: set[str] = set()  # trajectory commands sent and not yet answered
            bus.subscribe(JointTrajectoryCommand, lambda c: in_flight.add(c.command_id))
            bus.subscribe(JointTrajectoryResult, lambda r: in_flight.discard(r.command_id))
            bus.subscribe(Scene, scenes.put)
            bus.subscribe(SkillStatus, lambda s: statuses.put((time.perf_counter(), s)))
            bus.subscribe(JointState, joints.append)
            time.sleep(0.5)
            warm_up(bus)
            for sample in range(args.samples):
                episode = f"estop-{sample}"
                bus.request(
                    EpisodeRequest(episode_id=episode, task="stack", blocks=3, seed=sample),
                    EpisodeEvent,
                    timeout=60.0,
                )
                scene = scenes.get(timeout=10.0)
                while scene.episode_id != episode:
                    scene = scenes.get(timeout=10.0)
                block, goal = legal_first_move(scene)
                decision = f"{episode}:0"
                bus.publish(
                    Action(
                        decision_id=decision,
                        episode_id=episode,
                        scene_sequence=scene.sequence,
                        object_id=block,
                        goal_id=goal,
                        policy="bench",
                        stamp=time.time(),
                    )
                )
                _, status = statuses.get(timeout=10.0)
                while not (status.decision_id == decision and status.state is SkillState.RUNNING):
                    if status.decision_id == decision and status.state.terminal:
                        break
                    _, status = statuses.get(timeout=10.0)
                if status.state is not SkillState.RUNNING:  # refused: no stop to time
                    print(f"sample {sample}: the action was refused ({status.reason})")
                    continue
                time.sleep(rng.uniform(0.1, 0.6))
                # where the stop lands: a trajectory under way, or skills planning between them
                phase = "moving" if in_flight else "planning"
                sent, stop_stamp = time.perf_counter(), time.time()
                bus.publish(EmergencyStop(engaged=True, reason="bench", stamp=stop_stamp))
                arrived, status = statuses.get(timeout=10.0)
                while status.decision_id != decision or not status.state.terminal:
                    arrived, status = statuses.get(timeout=10.0)
                if status.reason != "stopped":
                    print(f"sample {sample}: the skill ended before the stop ({status.state})")
                else:
                    latencies.append((arrived - sent) * 1000)
                    phases.append(phase)
                    at_skills.append((status.stamp - stop_stamp) * 1000)
                    print(
                        f"sample {sample}: {latencies[-1]:.1f} ms ({phase}; skills stamped "
                        f"its status {at_skills[-1]:.1f} ms after the stop was sent)",
                        flush=True,
                    )
                    time.sleep(0.2)  # let the sim report the halted arm
                    before = np.array(joints[-1].positions)
                    time.sleep(0.3)
                    after = np.array(joints[-1].positions)
                    halted += bool(np.max(np.abs(after - before)) < 0.01)
                bus.publish(EmergencyStop(engaged=False, reason="bench", stamp=time.time()))
                time.sleep(0.3)
    if not latencies:
        raise SystemExit("no stop landed while a skill ran")
    print(
        f"emergency stop -> skill reports stopped: {distribution(latencies)} "
        f"(target 100 ms); arm still afterwards in {halted}/{len(latencies)}"
    )
    print(f"  stop sent -> skills stamps 'stopped': {distribution(at_skills)}")
    for phase in sorted(set(phases)):
        landed = [t for t, p in zip(latencies, phases, strict=True) if p == phase]
        print(f"  stops landing while {phase}: {distribution(landed)}")
    ordered = sorted(latencies)
    print(
        json.dumps(
            {
                "bench": "estop",
                "busy_processes": args.busy,
                "load": round(os.getloadavg()[0], 2),
                "stops": len(ordered),
                "p50_ms": round(statistics.median(ordered), 1),
                "p95_ms": round(ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))], 1),
                "max_ms": round(ordered[-1], 1),
                "limit_p95_ms": 100,
                "limit_max_ms": 200,
                "arm_still": halted,
            }
        )
    )


def distribution(latencies: list[float]) -> str:
    ordered = sorted(latencies)
    p95 = ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))]
    return (
        f"median {statistics.median(ordered):.1f} ms, p95 {p95:.1f} ms, "
        f"max {ordered[-1]:.1f} ms over {len(ordered)} stops"
    )


if __name__ == "__main__":
    main()
