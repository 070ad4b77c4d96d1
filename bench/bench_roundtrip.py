"""Scene -> Action round trip over Zenoh beside raw Zenoh echo of the same bytes, K = 3, 9, 40.

A real router, a planner and an echo process (``raw_echo.py``) run as processes on loopback.
For each K this client alternates two samples, so load on the machine hits both alike:

* **round trip**: publish a Scene of a fresh episode (the planner decides at once) and time
  the arrival of its Action, decoded and validated as any service would;
* **raw echo**: put the same number of bytes on the echo process's key and time them coming
  back (no decoding, no validation): the floor of any round trip through this router.

The expert policy is timed first; then (unless ``--policies expert``) the planner is restarted
with the shipped GraphSage checkpoint and its in-process decision time on the same scenes is
measured here too, since its target is ``2 x raw + decision``. Prints p50/p99 in milliseconds
and ratios, then one JSON line. Not a test: a figure to compare changes with.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import zenoh
from raw_echo import PING, PONG, open_client  # type: ignore[import-not-found]

from manigraph_shared.bus import Bus
from manigraph_shared.messages import Action, EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_testkit.testing import Stack, stack

ROOT = Path(__file__).resolve().parent.parent
CHECKPOINTS = {"expert": "expert", "sage": str(ROOT / "checkpoints" / "sage.pt")}


def scene_for(blocks: int, episode: str) -> Scene:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id=episode, task="stack", blocks=blocks, seed=1), 0.0)
    scene = sim.scene(time.time())
    assert scene is not None
    return scene


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


class Arrivals:
    """When each awaited reply arrived (perf_counter), filled on Zenoh threads."""

    def __init__(self) -> None:
        self.at: dict[str, float] = {}
        self.ready = threading.Condition()

    def mark(self, name: str) -> None:
        with self.ready:
            self.at[name] = time.perf_counter()
            self.ready.notify_all()

    def wait(self, name: str, timeout: float = 5.0) -> float:
        with self.ready:
            if not self.ready.wait_for(lambda: name in self.at, timeout=timeout):
                raise SystemExit(f"no reply for {name} within {timeout} s")
            return self.at.pop(name)


def decision_ms(policy_name: str, template: Scene, samples: int = 200) -> float:
    """The policy's own decision time on ``template``, in this process (median)."""
    from manigraph_planner.policies import load_policy

    policy = load_policy(CHECKPOINTS[policy_name])
    times = []
    for _ in range(samples + 10):
        start = time.perf_counter()
        policy.decide(template)
        times.append((time.perf_counter() - start) * 1e3)
    return statistics.median(times[10:])


def measure(
    bus: Bus, raw: zenoh.Session, arrivals: Arrivals, template: Scene, samples: int, tag: str
) -> tuple[list[float], list[float]]:
    echo = raw.declare_publisher(
        PING, congestion_control=zenoh.CongestionControl.DROP, express=True
    )
    size = len(template.encode())
    trip, floor = [], []
    for i in range(samples + 20):
        episode = f"bench-{tag}-{i}"
        scene = template.replace(episode_id=episode, stamp=time.time(), sequence=i)
        sent = time.perf_counter()
        bus.publish(scene)
        got = arrivals.wait(episode)
        payload = episode.encode().ljust(size, b" ")
        echoed = time.perf_counter()
        echo.put(payload)
        back = arrivals.wait(f"echo:{episode}")
        if i >= 20:  # warm-up excluded
            trip.append((got - sent) * 1e3)
            floor.append((back - echoed) * 1e3)
    echo.undeclare()
    return trip, floor


def start_planner(running: Stack, policy: str) -> None:
    if "planner" in running.processes:
        running.stop("planner")
    (running.log_dir / "planner.log").unlink(missing_ok=True)
    running.start("planner", "planner", "--policy", CHECKPOINTS[policy])


def wait_explainer(running: Stack, timeout: float = 120.0) -> None:
    """A GNN planner builds its explainer beside its decisions after it is ready (PyG's
    import): time the decisions once that is done, as a planner that has run a while."""
    deadline = time.monotonic() + timeout
    while "explainer ready" not in running.log("planner"):
        if time.monotonic() > deadline:
            raise SystemExit("the planner's explainer was not ready in time")
        time.sleep(0.2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 9, 40])
    parser.add_argument("--policies", nargs="+", default=["expert", "sage"], choices=CHECKPOINTS)
    args = parser.parse_args()
    cells = []
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        running.start("router")
        echo = subprocess.Popen(
            [sys.executable, str(ROOT / "bench" / "raw_echo.py"), running.endpoint]
        )
        try:
            raw = open_client(running.endpoint)
            arrivals = Arrivals()
            raw.declare_subscriber(
                PONG, lambda s: arrivals.mark("echo:" + bytes(s.payload).decode().rstrip())
            )
            with running.client() as bus:
                bus.subscribe(Action, lambda action: arrivals.mark(action.episode_id))
                for policy in args.policies:
                    start_planner(running, policy)
                    running.wait_alive(bus, "planner")
                    if policy != "expert":
                        wait_explainer(running)
                    time.sleep(0.3)
                    for blocks in args.blocks:
                        template = scene_for(blocks, "template")
                        trip, floor = measure(
                            bus, raw, arrivals, template, args.samples, f"{policy}-{blocks}"
                        )
                        decide = decision_ms(policy, template) if policy != "expert" else 0.0
                        raw_p50 = statistics.median(floor)
                        p50 = statistics.median(trip)
                        cells.append(
                            {
                                "k": blocks,
                                "policy": policy,
                                "bytes": len(template.encode()),
                                "p50_ms": round(p50, 3),
                                "p99_ms": round(percentile(trip, 0.99), 3),
                                "raw_p50_ms": round(raw_p50, 3),
                                "raw_p99_ms": round(percentile(floor, 0.99), 3),
                                "decide_ms": round(decide, 3),
                                "ratio_p50": round(p50 / raw_p50, 2),
                                "ratio_beyond_decision": round((p50 - decide) / raw_p50, 2),
                            }
                        )
            raw.close()
        finally:
            echo.terminate()
            echo.wait()
    load = os.getloadavg()[0]
    print(f"scene -> action round trip beside raw Zenoh echo of the same bytes (load {load:.2f})")
    print(
        f"{'policy':>7} {'K':>3} {'bytes':>6} {'p50 ms':>7} {'p99 ms':>7} {'raw p50':>8} "
        f"{'raw p99':>8} {'decide':>7} {'ratio':>6} {'(-dec)':>6}  target"
    )
    for c in cells:
        print(
            f"{c['policy']:>7} {c['k']:>3} {c['bytes']:>6} {c['p50_ms']:>7.2f} {c['p99_ms']:>7.2f} "
            f"{c['raw_p50_ms']:>8.2f} {c['raw_p99_ms']:>8.2f} {c['decide_ms']:>7.2f} "
            f"{c['ratio_p50']:>6.2f} {c['ratio_beyond_decision']:>6.2f}  <= 2.00"
        )
    print(json.dumps({"bench": "roundtrip", "load": round(load, 2), "cells": cells}))


if __name__ == "__main__":
    main()
