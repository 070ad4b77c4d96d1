"""How long ``manigraph replay --expect-actions`` takes to fail against a planner that diverges.

A fresh router and a planner serving another checkpoint than the one a golden log was
recorded with (by default the GCN checkpoint against ``tests/golden/sage-pyramid6.mcap``,
which differs at the second decision); once the planner is alive, the replay at its recorded
speed is timed from command to exit, by default (stop at the first divergence) and with
``--keep-going``. Target: <= 10 s by default (issue 45 item 6).

    .venv/bin/python bench/bench_replay_divergence.py [--log L] [--checkpoint C] [--runs 3]

One line per run, then a JSON summary with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from manigraph_testkit.testing import stack

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 10.0


def timed_replay(log: Path, checkpoint: Path, *extra: str) -> tuple[float, dict[str, object]]:
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        running.start("router")
        running.start("planner", "planner", "--policy", str(checkpoint))
        with running.client() as bus:
            running.wait_alive(bus, "router", "planner", timeout=180)
        started = time.monotonic()
        result = running.run("replay", str(log), "--expect-actions", *extra, timeout=600)
        seconds = time.monotonic() - started
        if result.returncode != 1:
            raise SystemExit(
                f"expected a divergence (exit 1), got {result.returncode}:\n{result.stderr[-2000:]}"
            )
        return seconds, json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--log", type=Path, default=ROOT / "tests" / "golden" / "sage-pyramid6.mcap"
    )
    parser.add_argument("--checkpoint", type=Path, default=ROOT / "checkpoints" / "gcn.pt")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    stops, keeps = [], []
    for index in range(args.runs):
        stop_s, summary = timed_replay(args.log, args.checkpoint)
        keep_s, _ = timed_replay(args.log, args.checkpoint, "--keep-going")
        stops.append(stop_s)
        keeps.append(keep_s)
        print(
            f"run {index}: fails in {stop_s:.2f} s ({summary['first_mismatch']}); "
            f"--keep-going {keep_s:.2f} s",
            flush=True,
        )
    print(
        json.dumps(
            {
                "fails_in_s": round(statistics.median(stops), 2),
                "keep_going_s": round(statistics.median(keeps), 2),
                "target_s": TARGET_S,
                "load_average": [round(v, 2) for v in os.getloadavg()],
                "runs": args.runs,
            }
        )
    )


if __name__ == "__main__":
    main()
