"""``manigraph rl-compare``: the paper's RL baselines against the shipped IL checkpoints."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--out",
        type=Path,
        default=Path("results/rl"),
        help="folder of every run, evaluation and the report; reused on a rerun "
        "(default: results/rl)",
    )
    parser.add_argument(
        "--baselines",
        nargs="+",
        default=["rl-mlp", "rl-gnn", "rl-gnn-seq", "rl-gnn-demo"],
        help="which RL baselines to train",
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds")
    parser.add_argument("--episodes", type=int, default=50, help="evaluation episodes per K")
    parser.add_argument(
        "--steps-per-stage", type=int, default=2000, help="environment interactions per K"
    )
    parser.add_argument("--n-steps", type=int, default=250, help="PPO rollout length")
    parser.add_argument(
        "--blocks",
        type=int,
        nargs="+",
        default=list(range(2, 10)),
        help="stack heights K, trained as a curriculum and evaluated (default: 2 to 9)",
    )
    parser.add_argument(
        "--il-checkpoints",
        type=Path,
        nargs="*",
        default=None,
        help="IL checkpoints to evaluate alongside (default: checkpoints/*.pt)",
    )
    parser.add_argument("--explain-decisions", type=int, default=100, help="0: no explainer")
    parser.add_argument("--imitation-weight", type=float, default=1.0, help="λ_IL of rl-gnn-demo")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    parser.add_argument("--json", action="store_true", help="quiet; last line: one JSON object")


def _run(args: argparse.Namespace) -> int:
    import torch

    from manigraph_lab.rl.baselines import PPOSettings
    from manigraph_lab.rl.compare import CompareSpec, run_comparison
    from manigraph_shared.errors import ConfigError

    if args.threads < 1:
        raise ConfigError("threads", f"must be >= 1, got {args.threads}")
    torch.set_num_threads(args.threads)
    checkpoints = (
        sorted(Path("checkpoints").glob("*.pt"))
        if args.il_checkpoints is None
        else args.il_checkpoints
    )
    spec = CompareSpec(
        out=args.out,
        baselines=tuple(args.baselines),
        seeds=tuple(args.seeds),
        episodes=args.episodes,
        il_checkpoints=tuple(checkpoints),
        explain_decisions=args.explain_decisions,
        settings=PPOSettings(
            steps_per_stage=args.steps_per_stage,
            n_steps=args.n_steps,
            batch_size=min(50, args.n_steps),
            blocks=tuple(args.blocks),
            imitation_weight=args.imitation_weight,
        ),
    )
    results = run_comparison(spec, show_progress=not args.json and sys.stdout.isatty())
    if args.json:
        print(
            json.dumps(
                {
                    "out": str(args.out),
                    "success_mean": {m: r["mean"] for m, r in results["methods"].items()},
                    "success_std": {m: r["std"] for m, r in results["methods"].items()},
                }
            )
        )
    else:
        print((args.out / "table.md").read_text())
    return 0


command = Command(
    help="train the paper's RL baselines (PPO) on K-block stacking and compare them with IL",
    configure=_configure,
    run=_run,
)
