"""Recorder throughput: how many samples per second reach the MCAP file.

A publisher sends Actions (BLOCK, never dropped) as fast as it can for a few seconds through a
real router to a real recorder process; the figure is samples written per second, and the
ratio of written to published (must be 1.0).

``--kill N``: N times, a recorder taking Actions at ~500/s is killed with SIGKILL, its file is
finalised with ``manigraph record --recover`` and read with the standard ``mcap`` reader; the
figure is the window of messages lost before the kill, in ms (median and worst; target 100).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from mcap.reader import make_reader

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action
from manigraph_testkit.testing import record_then_kill, stack


def lost_window_ms(tmp: Path, run: int) -> float:
    """Kill a recording recorder; ms of messages published before the kill that are lost."""
    with stack(tmp) as running:
        killed = record_then_kill(running, tmp / f"kill-{run}.mcap")
        recovered = running.run("record", "--recover", str(killed.log))
        assert recovered.returncode == 0, recovered.stderr
        with killed.log.open("rb") as stream:  # the standard reader, summary and all
            reader = make_reader(stream)
            assert reader.get_summary() is not None
            kept = {
                Action.decode(m.data).scene_sequence
                for _, channel, m in reader.iter_messages()
                if channel.topic == Action.key
            }
    return killed.lost_window_ms(kept)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--kill", type=int, default=0, help="also measure N kill -9 runs")
    args = parser.parse_args()
    if args.kill:
        with tempfile.TemporaryDirectory() as tmp:
            windows = [lost_window_ms(Path(tmp), run) for run in range(args.kill)]
        print("recorder kill -9, then manigraph record --recover, read with mcap's make_reader")
        print(f"{'runs':>5} {'median lost ms':>15} {'worst lost ms':>14} {'target':>7}")
        print(f"{args.kill:>5} {statistics.median(windows):>15.0f} {max(windows):>14.0f} {100:>7}")
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
                bus.publish(template.replace(scene_sequence=sent))
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
