"""Training wall time for the default recipe (20 demonstrations, 990 augmented graphs), per
architecture, beside its limit (60 s on two CPU threads) and the last release's figure.

    python bench/bench_training.py                    # the four architectures, 2 CPU threads
    python bench/bench_training.py --device cuda      # on a GPU; skipped, saying so, without one

``--batch-layout pyg`` times the PyG message-passing reference instead of padded batches.
Beside the wall time it gives the training process's own CPU time (without the draw worker's):
on a machine shared with other work, wall time grows with the load and CPU time much less.
Ends with one JSON line of its figures.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import torch

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_training.batch_layouts import BATCH_LAYOUTS
from manigraph_training.dataset import load_demonstrations
from manigraph_training.trainer import TrainConfig, train

LIMIT_SECONDS = 60.0
#: docs/benchmarks.md of the last release (2026-11-24, 2 threads, quiet machine).
LAST_RELEASE_SECONDS = {"gcn": 7.0, "sage": 67.0, "gated": 85.0, "gat": 97.0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--archs", nargs="+", default=["gcn", "sage", "gated", "gat"])
    parser.add_argument("--epochs", type=int, default=TrainConfig().epochs)
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    parser.add_argument("--threads", type=int, default=2, help="CPU threads (torch)")
    parser.add_argument(
        "--batch-layout", choices=sorted(BATCH_LAYOUTS), default=TrainConfig().batch_layout
    )
    args = parser.parse_args()
    if args.device.startswith("cuda") and not torch.cuda.is_available():
        print(
            f"skipped: --device {args.device} needs a CUDA device and torch sees none here "
            f"(torch {torch.__version__}, torch.cuda.is_available() is False)"
        )
        print(json.dumps({"bench": "training", "device": args.device, "skipped": "no CUDA"}))
        return
    torch.set_num_threads(args.threads)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demos.mcap"
        record_demos(load_policy("expert"), DemoProtocol(), path, progress=None)  # type: ignore[arg-type]
        demos = load_demonstrations([path])
    rows = []
    for arch in args.archs:
        started, cpu_started = time.perf_counter(), time.process_time()
        config = TrainConfig(
            architecture=arch,
            epochs=args.epochs,
            batch_layout=args.batch_layout,
            device=args.device,
        )
        _, metrics = train(demos, config, progress=None)
        rows.append(
            {
                "arch": arch,
                "seconds": round(time.perf_counter() - started, 1),
                "cpu_seconds": round(time.process_time() - cpu_started, 1),
                "limit_seconds": LIMIT_SECONDS,
                "last_release_seconds": LAST_RELEASE_SECONDS.get(arch),
                "demo_accuracy": metrics["demo_accuracy"],
            }
        )
    load = os.getloadavg()[0]
    print(
        f"training, default recipe ({len(demos.samples)} demo steps), {args.epochs} epochs, "
        f"{args.device}, {torch.get_num_threads()} threads, {args.batch_layout} batches "
        f"(load {load:.2f})"
    )
    print(
        f"{'arch':>6} {'seconds':>8} {'cpu s':>6} {'limit':>6} {'ratio':>6} {'last rel.':>9} "
        f"{'demo acc':>9}"
    )
    for row in rows:
        last = row["last_release_seconds"]
        print(
            f"{row['arch']:>6} {row['seconds']:>8.1f} {row['cpu_seconds']:>6.1f} "
            f"{LIMIT_SECONDS:>6.0f} "
            f"{row['seconds'] / LIMIT_SECONDS:>6.2f} {last if last else '-':>9} "
            f"{row['demo_accuracy']:>9.3f}"
        )
    print(
        json.dumps(
            {
                "bench": "training",
                "device": args.device,
                "threads": torch.get_num_threads(),
                "load": round(load, 2),
                "cells": rows,
            }
        )
    )


if __name__ == "__main__":
    main()
