"""``manigraph suite`` on Ray: the same cells with 1 worker and with 2, wall time and speed-up.

    .venv/bin/python bench/bench_ray_suite.py [--archs gcn sage] [--seeds 0 1] [--epochs 40]
        [--episodes 20] [--workers 2]

Records a few expert demonstrations once (4 box pack/unpack runs), then runs the same suite
(per architecture and seed: one training, then the 8 table cells, no curve) twice, each in a
fresh output folder and a fresh local Ray (``ray.init(num_cpus=N)``, started inside the timed
run as ``manigraph suite`` does): once with 1 worker, once with ``--workers``. Each task runs
torch on 1 thread, so the two runs do the same work; only how many cells run at once differs.
The success rates of both runs must be identical (exit status 1 otherwise).

The defaults make each run a minute or two of work: Ray's own start-up and shut-down (~10 s
here, inside both timings, as in ``manigraph suite``) is then what it is in a real sweep (the
suite's defaults, 150 epochs and 100 episodes a cell, run for hours), not most of the figure.

Target (issue 29): 2 workers >= 1.7x faster than 1 on this 2-core machine. The load average
before and after is printed: on a shared machine the second core may not be free.
Last line: one JSON object ``{"bench": "ray_suite", ...}``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from manigraph_lab.demos import DemoProtocol, record_demos
from manigraph_lab.suite import cells as table_cells
from manigraph_lab.suite import run_suite
from manigraph_lab.sweep import SweepOptions
from manigraph_planner.policies import load_policy

SPEEDUP_TARGET = 1.7


def timed_suite(
    root: Path, demos: bytes, args: argparse.Namespace, workers: int
) -> tuple[float, dict[str, object]]:
    out = root / f"workers-{workers}"
    out.mkdir()
    (out / "demos.mcap").write_bytes(demos)
    started = time.perf_counter()
    summary = run_suite(
        out,
        args.archs,
        args.seeds,
        episodes=args.episodes,
        curve_episodes=0,
        epochs=args.epochs,
        sweep=SweepOptions(workers=workers, ray=True, threads=1),
    )
    return time.perf_counter() - started, summary


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--archs", nargs="+", default=["gcn", "sage"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--epochs", type=int, default=40)
    parser.add_argument("--episodes", type=int, default=20, help="episodes per table cell")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    import ray

    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench-ray-suite-") as tmp:
        root = Path(tmp)
        demo_path = root / "demos.mcap"
        record_demos(load_policy("expert"), DemoProtocol(trajectories=4), demo_path, None)
        demos = demo_path.read_bytes()
        one_s, one = timed_suite(root, demos, args, 1)
        many_s, many = timed_suite(root, demos, args, args.workers)
    load_after = os.getloadavg()
    cells = len(args.archs) * len(args.seeds) * (1 + len(table_cells(args.episodes)))
    identical = one["results"] == many["results"]
    speedup = one_s / many_s
    print(f"cells: {cells} ({len(args.archs)} archs x {len(args.seeds)} seeds x (training + 8))")
    print(f"1 worker:  {one_s:7.1f} s")
    print(f"{args.workers} workers: {many_s:7.1f} s")
    print(f"speed-up:  {speedup:7.2f}x (target >= {SPEEDUP_TARGET}x)")
    print(f"success rates identical: {identical}")
    loads = f"before {load_before[0]:.2f}, after {load_after[0]:.2f}"
    print(f"load average {loads}, cpus {os.cpu_count()}")
    print(
        json.dumps(
            {
                "bench": "ray_suite",
                "cells": cells,
                "episodes_per_cell": args.episodes,
                "epochs": args.epochs,
                "workers": args.workers,
                "one_worker_s": round(one_s, 2),
                "many_workers_s": round(many_s, 2),
                "speedup": round(speedup, 3),
                "target": SPEEDUP_TARGET,
                "meets_target": speedup >= SPEEDUP_TARGET,
                "identical_success_rates": identical,
                "load_before": [round(x, 2) for x in load_before],
                "load_after": [round(x, 2) for x in load_after],
                "cpus": os.cpu_count(),
                "ray": ray.__version__,
            }
        )
    )
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
