"""``manigraph dishwasher-experiment``: the paper's Table 'dishwasher', reproduced
(:mod:`manigraph_dishwasher.dishwasher_table`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_dishwasher.dishwasher_table import ExperimentConfig, run_experiment
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--out",
        type=Path,
        default=Path("results/dishwasher"),
        help="folder of table.md and table.json (default: results/dishwasher)",
    )
    parser.add_argument("--arch", default="sage", help="architecture: gcn, sage, gated or gat")
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds (default: 0 1 2)"
    )
    parser.add_argument("--episodes", type=int, default=100, help="episodes per table cell")
    parser.add_argument("--epochs", type=int, default=300, help="training epochs (default: 300)")
    parser.add_argument(
        "--checkpoints", type=Path, default=Path("checkpoints"), help="where seed 0's nets go"
    )
    parser.add_argument(
        "--jobs", type=int, default=1, help="(preference, seed) runs at once, one process each"
    )


def _run(args: argparse.Namespace) -> int:
    import torch

    torch.set_num_threads(1)
    config = ExperimentConfig(
        args.out,
        args.arch,
        tuple(args.seeds),
        5,
        args.episodes,
        args.epochs,
        args.checkpoints,
        args.jobs,
    )
    summary = run_experiment(config, sys.stderr)
    print((config.out / "table.md").read_text(), end="")
    print(json.dumps({"table": str(config.out / "table.json"), "seconds": summary["seconds"]}))
    return 0


command = Command(
    help="the paper's dishwasher table: 5 demos, 3 seeds, 6-12 dishes, both preferences",
    configure=_configure,
    run=_run,
)
