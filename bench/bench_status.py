"""`manigraph status` and a refused `manigraph run`, timed as a person types them.

A real router, the geometric sim, skills and the expert planner run as processes on loopback.
The bench times, as whole commands (a new Python process each, imports included):

* ``manigraph status --json`` on the live stack, ``--samples`` times; also the part inside
  the command from opening the bus to the last status (its ``seconds`` field);
* ``manigraph run --episodes 3`` with the emergency stop engaged, ``--samples`` times: it must
  exit non-zero with reason ``estop_engaged``.

Targets (issue #45): status answers within 1 s; run on a stopped stack is refused within 2 s.
Prints one line per sample, the load average, and one JSON line. Not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from manigraph_testkit.testing import stack


def timed(running, *args: str) -> tuple[float, subprocess.CompletedProcess[str]]:  # type: ignore[no-untyped-def]
    started = time.perf_counter()
    result = running.run(*args, timeout=120)
    return time.perf_counter() - started, result


def summary(values: list[float]) -> dict[str, float]:
    return {
        "median_s": round(statistics.median(values), 3),
        "max_s": round(max(values), 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder, stack(Path(folder)) as running:
        running.start("router")
        for name in ("sim", "skills", "planner"):
            running.start(name, name)
        with running.client() as bus:
            running.wait_alive(bus, "sim", "skills", "planner", timeout=180)
        time.sleep(1.0)
        status_wall, status_inside = [], []
        for index in range(args.samples):
            seconds, result = timed(running, "status", "--json")
            report = json.loads(result.stdout.strip().splitlines()[-1])
            alive = sum(s["alive"] for s in report["services"])
            assert result.returncode == 0 and alive == 4, result.stderr
            status_wall.append(seconds)
            status_inside.append(report["seconds"])
            print(
                f"status {index + 1}: {seconds:.3f} s (bus + statuses {report['seconds']:.3f} s)",
                file=sys.stderr,
            )
        assert running.run("stop", "--reason", "bench", timeout=60).returncode == 0
        refused = []
        for index in range(args.samples):
            seconds, result = timed(running, "run", "--episodes", "3", "--json")
            reason = json.loads(result.stdout.strip().splitlines()[-1])["results"][0]["reason"]
            assert result.returncode != 0 and reason.startswith("estop_engaged"), reason
            refused.append(seconds)
            print(f"run refused {index + 1}: {seconds:.3f} s ({reason})", file=sys.stderr)
        running.run("resume", timeout=60)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", file=sys.stderr)
    print(
        json.dumps(
            {
                "status": summary(status_wall),
                "status_inside": summary(status_inside),
                "run_refused": summary(refused),
                "targets": {"status_s": 1.0, "run_refused_s": 2.0},
                "load": round(load[0], 2),
            }
        )
    )


if __name__ == "__main__":
    main()
