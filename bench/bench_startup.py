"""``manigraph up --episodes 1`` from command to its JSON line, beside the floor of a process
start measured in the same run (``python -c pass``: what any manigraph process costs before it
imports anything).

    python bench/bench_startup.py --runs 5

Cells: the geometric world with the expert (target 3 s) and the physics Panda with the shipped
GraphSage checkpoint (target 10 s), each a 4-block stack, seed 0. Ends with one JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from manigraph_testkit.testing import free_port

ROOT = Path(__file__).resolve().parent.parent
CELLS = {
    "geometric-expert": (["--sim", "geometric", "--policy", "expert"], 3.0),
    "physics-sage": (["--sim", "physics", "--policy", str(ROOT / "checkpoints" / "sage.pt")], 10.0),
}


def timed(argv: list[str]) -> float:
    started = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed:\n{done.stderr[-2000:]}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--cells", nargs="+", default=list(CELLS), choices=CELLS)
    args = parser.parse_args()
    floor = statistics.median(timed([sys.executable, "-c", "pass"]) for _ in range(args.runs))
    rows = []
    for name in args.cells:
        flags, limit = CELLS[name]
        argv = [sys.executable, "-m", "manigraph_shared.cli", "up", *flags]
        argv += ["--task", "stack", "--blocks", "4", "--episodes", "1", "--seed", "0", "--json"]
        times = sorted(timed([*argv, "--port", str(free_port())]) for _ in range(args.runs))
        rows.append(
            {
                "cell": name,
                "p50_s": round(statistics.median(times), 2),
                "max_s": round(times[-1], 2),
                "limit_s": limit,
                "process_floor_s": round(floor, 3),
            }
        )
    load = os.getloadavg()[0]
    print(f"manigraph up --episodes 1, command to JSON, {args.runs} runs (load {load:.2f})")
    print(f"{'cell':>18} {'p50 s':>6} {'max s':>6} {'limit':>6} {'python -c pass':>15}")
    for row in rows:
        print(
            f"{row['cell']:>18} {row['p50_s']:>6.2f} {row['max_s']:>6.2f} {row['limit_s']:>6.1f} "
            f"{row['process_floor_s']:>15.3f}"
        )
    print(json.dumps({"bench": "startup", "load": round(load, 2), "cells": rows}))


if __name__ == "__main__":
    main()
