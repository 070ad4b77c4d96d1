"""Scene -> Action round trip over Zenoh with the expert policy, K = 3, 9, 40.

A real router and planner run as processes on loopback; this client publishes a Scene of a
fresh episode (so the planner decides at once) and times the arrival of its Action.
Prints p50/p99 in milliseconds. Not a test: a figure to compare changes with.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
import time
from pathlib import Path

from manigraph_shared.messages import Action, EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_tools.testing import stack


def scene_for(blocks: int, episode: str) -> Scene:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id=episode, task="stack", blocks=blocks, seed=1), 0.0)
    scene = sim.scene(time.time())
    assert scene is not None
    return scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 9, 40])
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        running.start("router")
        running.start("planner", "planner", "--policy", "expert")
        with running.client() as bus:
            running.wait_alive(bus, "planner")
            arrived: dict[str, float] = {}
            ready = threading.Condition()

            def on_action(action: Action) -> None:
                with ready:
                    arrived[action.episode_id] = time.perf_counter()
                    ready.notify_all()

            bus.subscribe(Action, on_action)
            time.sleep(0.3)
            for blocks in args.blocks:
                template = scene_for(blocks, "template")
                times = []
                for i in range(args.samples + 20):
                    episode = f"bench-{blocks}-{i}"
                    scene = template.model_copy(
                        update={"episode_id": episode, "stamp": time.time(), "sequence": i}
                    )
                    sent = time.perf_counter()
                    bus.publish(scene)
                    with ready:
                        if not ready.wait_for(lambda e=episode: e in arrived, timeout=5):
                            raise SystemExit(f"no action for {episode}")
                    if i >= 20:  # warm-up excluded
                        times.append((arrived[episode] - sent) * 1e3)
                times.sort()
                rows.append(
                    (blocks, 2 * blocks, statistics.median(times), times[int(0.99 * len(times))])
                )
    print("scene -> action round trip over Zenoh (router + planner processes, expert policy)")
    print(f"{'K':>4} {'nodes':>6} {'p50 ms':>8} {'p99 ms':>8}")
    for blocks, nodes, p50, p99 in rows:
        print(f"{blocks:>4} {nodes:>6} {p50:>8.2f} {p99:>8.2f}")


if __name__ == "__main__":
    main()
