"""``manigraph train`` for the dishwasher family: its four-headed policy, trained by its own
loop (:mod:`.training`) on the CPU, written to ``runs/dishwasher-<arch>-seed<seed>.pt``
unless ``-o`` names the file."""

from __future__ import annotations

import argparse
import json

from manigraph_shared.errors import ConfigError
from manigraph_shared.results import checkpoint_field, rounded
from manigraph_training.commands.train import RUNS


def train_from_args(args: argparse.Namespace) -> int:
    """``manigraph train`` for dishwasher demonstrations (its ``--heads`` is dishwasher)."""
    if args.device != "cpu":
        raise ConfigError("device", "the dishwasher recipe trains on the CPU only")
    from dataclasses import asdict

    from manigraph_dishwasher.training.loop import (
        DishTrainConfig,
        load_dish_demonstrations,
        train_dish,
    )
    from manigraph_planner.gnn import save_checkpoint

    defaults = DishTrainConfig()
    config = DishTrainConfig(
        architecture=args.arch,
        seed=args.seed,
        epochs=defaults.epochs if args.epochs is None else args.epochs,
        copies=defaults.copies if args.copies is None else args.copies,
    )
    demos = load_dish_demonstrations(args.demos)
    net, metrics = train_dish(demos, config)
    if config.epochs == 0:  # the checkpoint says so: a baseline, not a learned policy
        metrics = {**metrics, "untrained": True}
    output = args.output or RUNS / f"dishwasher-{args.arch}-seed{args.seed}.pt"
    output.parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(
        output,
        net,
        training_config={**asdict(config), "demos": [str(p) for p in args.demos]},
        data_hash=demos.data_hash,
        metrics={**metrics, "episodes": demos.episodes},
    )
    print(json.dumps(rounded({**checkpoint_field(output), "heads": "dishwasher", **metrics})))
    return 0
