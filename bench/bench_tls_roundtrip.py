"""Scene -> Action round trip, mutual TLS + access control vs plain TCP, side by side, K = 9.

Two stacks run at once on loopback, each a router and an expert planner as processes: one
plain TCP, one with the certificates of ``manigraph certs`` (made in a temporary directory)
and the router's access control. A client on each publishes a Scene of a fresh episode, as the
sim would (in the TLS stack it presents the sim's certificate), and times the planner's Action.
Samples alternate between the two stacks so that load on the machine hits both alike.
Prints p50/p99 in milliseconds and the TLS/plain ratio of the medians (target <= 1.2).
Not a test: a figure to compare changes with.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import threading
import time
from contextlib import ExitStack
from pathlib import Path

from bench_roundtrip import scene_for  # type: ignore[import-not-found]

from manigraph_shared.bus import Bus
from manigraph_shared.messages import Action, Scene
from manigraph_testkit.testing import Stack, stack
from manigraph_tools.certificates import make_certificates


class Timer:
    """Times scene -> action on one stack's client session."""

    def __init__(self, bus: Bus, name: str) -> None:
        self.bus = bus
        self.name = name
        self.arrived: dict[str, float] = {}
        self.ready = threading.Condition()
        self.times: list[float] = []
        bus.subscribe(Action, self._on_action)

    def _on_action(self, action: Action) -> None:
        with self.ready:
            self.arrived[action.episode_id] = time.perf_counter()
            self.ready.notify_all()

    def sample(self, template: Scene, index: int, keep: bool) -> None:
        episode = f"bench-{self.name}-{index}"
        scene = template.replace(episode_id=episode, stamp=time.time(), sequence=index)
        sent = time.perf_counter()
        self.bus.publish(scene)
        with self.ready:
            if not self.ready.wait_for(lambda: episode in self.arrived, timeout=5):
                raise SystemExit(f"{self.name}: no action for {episode}")
        if keep:
            self.times.append((self.arrived[episode] - sent) * 1e3)


def start(running: Stack) -> None:
    running.start("router")
    running.start("planner", "planner", "--policy", "expert")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=300, help="per stack")
    parser.add_argument("--blocks", type=int, default=9)
    args = parser.parse_args()
    with ExitStack() as resources:
        work = Path(resources.enter_context(tempfile.TemporaryDirectory()))
        certs = work / "certs"
        make_certificates(certs, ["router", "planner", "sim"])
        (work / "plain").mkdir()
        (work / "tls").mkdir()
        plain = resources.enter_context(stack(work / "plain"))
        secure = resources.enter_context(stack(work / "tls", tls_dir=certs))
        start(plain)
        start(secure)
        timers = []
        for name, running in (("tcp", plain), ("tls", secure)):
            bus = resources.enter_context(running.client(identity="sim"))
            running.wait_alive(bus, "planner", timeout=120)
            timers.append(Timer(bus, name))
        time.sleep(0.3)
        template = scene_for(args.blocks, "template")
        warm_up = 20
        for i in range(args.samples + warm_up):
            order = timers if i % 2 == 0 else timers[::-1]
            for timer in order:
                timer.sample(template, i, keep=i >= warm_up)
    print(
        f"scene -> action round trip, K = {args.blocks} ({2 * args.blocks} nodes), expert "
        f"planner, {args.samples} samples each, interleaved"
    )
    print(f"{'transport':>30} {'p50 ms':>8} {'p99 ms':>8}")
    medians = {}
    for timer, label in zip(timers, ("plain TCP", "mutual TLS + access control"), strict=True):
        times = sorted(timer.times)
        medians[timer.name] = statistics.median(times)
        print(f"{label:>30} {medians[timer.name]:>8.2f} {times[int(0.99 * len(times))]:>8.2f}")
    ratio = medians["tls"] / medians["tcp"]
    print(f"{'ratio of medians TLS / TCP':>30} {ratio:>8.2f}  (target <= 1.2)")
    cells = {
        timer.name: {
            "p50_ms": round(medians[timer.name], 3),
            "p99_ms": round(sorted(timer.times)[int(0.99 * len(timer.times))], 3),
        }
        for timer in timers
    }
    print(
        json.dumps(
            {
                "bench": "tls_roundtrip",
                "k": args.blocks,
                "load": round(os.getloadavg()[0], 2),
                **cells,
                "ratio_p50": round(ratio, 3),
                "limit_ratio": 1.2,
            }
        )
    )


if __name__ == "__main__":
    main()
