"""Recorder throughput: how many samples per second reach the MCAP file.

A publisher sends Actions (BLOCK, never dropped) as fast as it can for a few seconds through a
real router to a real recorder process; the figure is samples written per second, and the
ratio of written to published (must be 1.0).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action
from manigraph_tools.testing import stack


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, stack(Path(tmp)) as running:
        log = Path(tmp) / "bench.mcap"
        running.start("router")
        running.start("recorder", "record", "--output", str(log))
        with running.client() as bus:
            running.wait_alive(bus, "recorder")
            time.sleep(0.3)
            template = Action(
                decision_id="e:0",
                episode_id="e",
                scene_sequence=0,
                object_id="block_0",
                goal_id="goal_0",
                policy="bench",
                stamp=time.time(),
            )
            payload_size = len(template.encode())
            sent = 0
            start = time.perf_counter()
            while time.perf_counter() - start < args.seconds:
                bus.publish(template.model_copy(update={"scene_sequence": sent}))
                sent += 1
            elapsed = time.perf_counter() - start
            time.sleep(0.5)
        running.stop("recorder")
        written = sum(1 for _ in read_log(log, [Action.key]))
    print("recorder throughput (router + recorder processes, Action samples, BLOCK)")
    print(f"{'published/s':>12} {'written':>9} {'published':>10} {'ratio':>6} {'bytes/msg':>10}")
    print(
        f"{sent / elapsed:>12.0f} {written:>9} {sent:>10} {written / sent:>6.3f} {payload_size:>10}"
    )


if __name__ == "__main__":
    main()
