"""``manigraph explain-study``: the paper's Table "gnn"
(:mod:`manigraph_lab.explanation_study`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from manigraph_shared.cli import Command


def _study_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--out",
        type=Path,
        default=Path("results/explain-study"),
        help="folder of the table (default: results/explain-study)",
    )
    parser.add_argument(
        "--archs",
        nargs="+",
        default=["gat", "gated", "gcn", "sage"],
        help="architectures to train and explain (default: gat gated gcn sage)",
    )
    parser.add_argument(
        "--trajectories", type=int, nargs="+", default=[5, 100], help="training set sizes"
    )
    parser.add_argument("--decisions", type=int, default=100, help="decisions explained per cell")
    parser.add_argument("--epochs", type=int, default=150, help="training epochs (default: 150)")
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of training and explaining (default: 0)"
    )
    parser.add_argument(
        "--demo-tasks",
        nargs="+",
        default=["box-pack", "box-unpack"],
        help="tasks the training demonstrations are drawn from (default: box-pack box-unpack)",
    )


def _study_run(args: argparse.Namespace) -> int:
    import torch

    from manigraph_lab.explanation_study import StudySpec, run_study

    torch.set_num_threads(2)
    spec = StudySpec(
        archs=tuple(args.archs),
        trajectories=tuple(args.trajectories),
        decisions=args.decisions,
        epochs=args.epochs,
        seed=args.seed,
        demo_tasks=tuple(args.demo_tasks),
    )
    table = run_study(spec, args.out, progress=sys.stderr)  # bars on a terminal only
    print(table)
    return 0


command = Command(
    help="reproduce the paper's Table 'gnn': top-2 features per architecture and data size",
    configure=_study_configure,
    run=_study_run,
)
