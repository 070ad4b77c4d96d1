"""Training wall time for the default protocol (20 demonstrations, 990 augmented graphs),
per architecture, on this machine's CPU. Target: <= 120 s per architecture on 2 cores.
``--batch-layout pyg`` times the PyG message-passing reference instead of padded batches."""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import torch

from manigraph_lab.demos import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_planner.training.batch_layouts import BATCH_LAYOUTS
from manigraph_planner.training.dataset import load_demonstrations
from manigraph_planner.training.trainer import TrainConfig, train


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--archs", nargs="+", default=["gcn", "sage", "gated", "gat"])
    parser.add_argument("--epochs", type=int, default=TrainConfig().epochs)
    parser.add_argument(
        "--batch-layout", choices=sorted(BATCH_LAYOUTS), default=TrainConfig().batch_layout
    )
    args = parser.parse_args()
    torch.set_num_threads(2)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "demos.mcap"
        record_demos(load_policy("expert"), DemoProtocol(), path, progress=None)  # type: ignore[arg-type]
        demos = load_demonstrations([path])
    rows = []
    for arch in args.archs:
        started = time.perf_counter()
        config = TrainConfig(architecture=arch, epochs=args.epochs, batch_layout=args.batch_layout)
        _, metrics = train(demos, config, progress=None)
        rows.append((arch, time.perf_counter() - started, metrics["demo_accuracy"]))
    print(
        f"training, default protocol ({len(demos.samples)} demo steps), {args.epochs} epochs, "
        f"{torch.get_num_threads()} threads, {args.batch_layout} batches"
    )
    print(f"{'arch':>6} {'seconds':>8} {'vs 120 s':>9} {'demo acc':>9}")
    for arch, seconds, acc in rows:
        print(f"{arch:>6} {seconds:>8.1f} {seconds / 120:>9.2f} {acc:>9.3f}")


if __name__ == "__main__":
    main()
