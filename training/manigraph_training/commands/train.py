"""``manigraph train``: learn a GNN policy from MCAP demonstrations (or a LeRobot dataset
that ``manigraph export`` wrote), write a checkpoint.

The logs say which policy they teach: each decision's scene belongs to a task family
(``families``), whose heads it trains; a family with a training loop of its own (the
dishwasher's four heads) runs it, any other the generic trainer with the paper's object and
goal heads. ``--heads`` chooses where a log holds both. Scenes whose objects carry attributes or
whose goals list what they accept (a task file's) train with the task's feature columns,
learned from the scenes and stamped in the checkpoint (docs/training.md)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from manigraph_planner.threads import add_threads_option, use_threads
from manigraph_shared.cli import Command
from manigraph_shared.results import checkpoint_field, rounded

#: Where a checkpoint goes without ``-o``: untracked (.gitignore), so training never
#: overwrites the shipped policies in ``checkpoints/``.
RUNS = Path("runs")


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "demos",
        type=Path,
        nargs="+",
        help="MCAP logs with scenes and actions, or LeRobot dataset folders (meta/info.json)",
    )
    parser.add_argument("--arch", default="sage", help="architecture: gcn, sage, gated or gat")
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the weights and the augmentation (default: 0)"
    )
    parser.add_argument(
        "--device", default="cpu", help="cpu, cuda or cuda:N (block policies; default cpu)"
    )
    parser.add_argument(
        "--epochs",
        type=int,
        help="full passes (default: 150; dishwasher heads: 300); 0 writes the network "
        "untrained, the baseline beside a learned one",
    )
    from manigraph_planner.family import FAMILIES

    heads = {family.heads: name for name, family in FAMILIES.items()}
    parser.add_argument(
        "--heads",
        choices=["auto", *heads],
        default="auto",
        help="the policy to train, by its heads: "
        + ", ".join(f"{h} ({family})" for h, family in heads.items())
        + "; auto (default): what the logs' decisions are",
    )
    parser.add_argument(
        "--copies",
        type=int,
        help="augmented copies per sample (default: 16; gcn: 8; dishwasher: 4 with dishes dropped)",
    )
    parser.add_argument(
        "--resample-every",
        type=int,
        help="draw fresh copies every N epochs (default: 10; gcn: 0, never)",
    )
    parser.add_argument(
        "--grow",
        type=int,
        metavar="N",
        help="task files: add up to N copies of the decided pair and of finished pairs to "
        "each augmented copy, so scenes grow past the demonstrated size (docs/training.md)",
    )
    parser.add_argument(
        "--decoder",
        choices=["nodes", "pairs"],
        default="nodes",
        help="block policies: 'nodes', the paper's two softmaxes (objects, goals; default), or "
        "'pairs', one softmax over (object, goal) pairs, the goal picked given the object "
        "(docs/training.md)",
    )
    add_threads_option(parser)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        help=f"checkpoint file to write (default {RUNS}/<arch>-seed<seed>.pt; "
        f"dishwasher: {RUNS}/dishwasher-<arch>-seed<seed>.pt)",
    )


def _heads(args: argparse.Namespace) -> str:
    from manigraph_shared.errors import ConfigError
    from manigraph_training.dataset import count_heads

    if args.heads != "auto":
        return str(args.heads)
    counts = count_heads(args.demos)
    present = [heads for heads, count in counts.items() if count]
    if len(present) > 1:
        found = ", ".join(f"{count} {heads}" for heads, count in counts.items())
        raise ConfigError(
            "heads", f"the logs hold decisions for both policies ({found}): choose one"
        )
    return present[0] if present else "object-goal"  # none: the loader says so, naming it


def _run(args: argparse.Namespace) -> int:
    from manigraph_planner.family import family_for_heads

    use_threads(args.threads)
    own_command = family_for_heads(_heads(args)).part("train_command")
    if own_command is not None:  # a family with a training loop of its own (the dishwasher)
        return int(own_command(args))
    from manigraph_planner.gnn import save_checkpoint
    from manigraph_training.dataset import load_demonstrations
    from manigraph_training.recipes import augmentation_for
    from manigraph_training.trainer import TrainConfig, train

    def configured(family: str | None) -> TrainConfig:
        """The run's config, its augmentation drawn from ``family``'s recipes."""
        config = TrainConfig(
            architecture=args.arch,
            seed=args.seed,
            epochs=150 if args.epochs is None else args.epochs,
            resample_every=args.resample_every,
            device=args.device,
            decoder=args.decoder,
            family=family,
        )
        if args.copies is not None:
            copies = augmentation_for(args.arch, copies=args.copies, family=family)
            config = replace(config, augmentation=copies)
        return config

    # TrainConfig checks the architecture (ModelConfig) and takes the defaults of its recipe
    # (training.recipes); each raises a ConfigError naming the field, before the logs are read.
    configured(None)
    demos = load_demonstrations(args.demos)
    # The recipe of the demonstrations' family (the fallback's for several, or one without);
    # a task's columns, its augmentation for them.
    config = configured(demos.family).for_task(demos.feature_spec)
    if args.grow is not None and config.augmentation is not None:
        config = replace(config, augmentation=config.augmentation.grown(args.grow))
    net, metrics = train(demos, config, progress=sys.stderr)  # a bar on a terminal only
    output = args.output or RUNS / f"{args.arch}-seed{args.seed}.pt"
    output.parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(
        output,
        net,
        training_config={**config.to_dict(), "demos": [str(p) for p in args.demos]},
        data_hash=demos.data_hash,
        metrics=metrics,
    )
    features = list(demos.feature_spec.names)
    print(json.dumps(rounded({**checkpoint_field(output), **metrics, "features": features})))
    return 0


command = Command(
    help="train a GNN policy by imitation from MCAP demonstrations", configure=_configure, run=_run
)
