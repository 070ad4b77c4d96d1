"""``manigraph train``: learn a GNN policy from MCAP demonstrations, write a checkpoint."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("demos", type=Path, nargs="+", help="MCAP logs with scenes and actions")
    parser.add_argument("--arch", default="sage", help="architecture: gcn, sage, gated or gat")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--epochs", type=int, default=150)
    parser.add_argument(
        "--copies", type=int, help="augmented copies per sample (default: 16; gcn: 8)"
    )
    parser.add_argument(
        "--resample-every",
        type=int,
        help="draw fresh copies every N epochs (default: 10; gcn: 0, never)",
    )
    parser.add_argument("-o", "--output", type=Path, help="checkpoint (default checkpoints/)")


def _run(args: argparse.Namespace) -> int:
    import torch

    from manigraph_planner.gnn import save_checkpoint
    from manigraph_planner.training.dataset import load_demonstrations
    from manigraph_planner.training.recipes import augmentation_for
    from manigraph_planner.training.trainer import TrainConfig, default_output, train

    # TrainConfig checks the architecture (ModelConfig) and takes the defaults of its recipe
    # (training.recipes); each raises a ConfigError naming the field.
    config = TrainConfig(
        architecture=args.arch,
        seed=args.seed,
        epochs=args.epochs,
        resample_every=args.resample_every,
    )
    if args.copies is not None:
        config = replace(config, augmentation=augmentation_for(args.arch, copies=args.copies))
    torch.set_num_threads(2)
    demos = load_demonstrations(args.demos)
    net, metrics = train(demos, config, progress=sys.stderr)  # a bar on a terminal only
    output = args.output or default_output(args.arch, args.seed)
    output.parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(
        output,
        net,
        training_config={**config.to_dict(), "demos": [str(p) for p in args.demos]},
        data_hash=demos.data_hash,
        metrics=metrics,
    )
    print(json.dumps({"checkpoint": str(output), **metrics}))
    return 0


command = Command(
    help="train a GNN policy by imitation from MCAP demonstrations", configure=_configure, run=_run
)
