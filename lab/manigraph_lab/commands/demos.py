"""``manigraph demos``: expert demonstrations recorded as MCAP
(:mod:`manigraph_lab.demo_recording`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from manigraph_lab.task_files import checked_files
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError

if TYPE_CHECKING:
    from manigraph_lab.demo_recording import DemoProtocol


def _demos_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        default=Path("data/demos.mcap"),
        help="the MCAP log to write (default: data/demos.mcap)",
    )
    parser.add_argument(
        "--tasks",
        nargs="+",
        default=["box-pack", "box-unpack"],
        metavar="TASK",
        help="tasks to demonstrate, each by its registered expert (default: box-pack "
        "box-unpack; `manigraph keys` and docs/running.md list the tasks)",
    )
    parser.add_argument(
        "--blocks",
        type=int,
        nargs="+",
        default=[3, 4],
        metavar="K",
        help="block counts to demonstrate each task with (default: 3 4)",
    )
    parser.add_argument(
        "--trajectories",
        type=int,
        default=20,
        help="demonstrations in all, spread over the tasks and block counts (default: 20)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the first demonstration (default: 0)"
    )
    parser.add_argument(
        "--objects",
        type=int,
        help="objects of a task that takes them (dishwasher: dishes, half plates, half bowls; "
        "default 10); a task that does not is refused naming the field",
    )
    parser.add_argument(
        "--preference",
        help="how the dishwasher is loaded: top-bottom (default) or left-right; the family's "
        "expert of that preference demonstrates it",
    )
    parser.add_argument(
        "--task-file",
        type=Path,
        help="demonstrate your own TOML layout instead of --tasks (docs/task-files.md), by the "
        "expert that solves any task file",
    )
    parser.add_argument(
        "--rules",
        type=Path,
        help="with --task-file: rules only the teacher and the judge know (docs/task-files.md); "
        "the expert follows them, the recorded scenes never show them",
    )


def _demos_run(args: argparse.Namespace) -> int:
    from manigraph_lab.demo_recording import DemoProtocol, record_demos

    protocol = DemoProtocol(
        tuple(args.tasks),
        tuple(args.blocks),
        args.trajectories,
        args.seed,
        objects=args.objects,
        preference=args.preference,
    )
    if args.rules is not None and args.task_file is None:
        raise ConfigError("rules", "rules judge a task file's goals; give --task-file too")
    if args.task_file is not None and (args.objects, args.preference) != (None, None):
        raise ConfigError(
            "task_file", "a task file lays out its own objects: drop --objects and --preference"
        )
    if args.task_file is not None:
        protocol = _task_file_protocol(args.task_file, protocol, args.rules)
    # Each task's family's expert (demos.family_expert): ``expert`` for the block tasks and
    # task files, the dishwasher's for ``dishwasher``.
    summary = record_demos(None, protocol, args.output, sys.stderr)
    print(json.dumps(summary))
    return 0


def _task_file_protocol(
    path: Path, protocol: DemoProtocol, rules: Path | None = None
) -> DemoProtocol:
    """``protocol``'s episodes drawn from the task file at ``path``, judged (and taught) by the
    rules file at ``rules`` (a bad file stops here, naming the field, before any episode)."""
    from dataclasses import replace

    from manigraph_tools.episode_plan import EpisodeOptions

    episodes = EpisodeOptions(task_file=path, rules=rules)
    text, blocks, rules_text = checked_files(episodes)
    assert text is not None
    return replace(
        protocol,
        blocks=(blocks,),
        task_file=text,
        task_file_name=episodes.label(),
        rules=rules_text,
    )


command = Command(
    help="record expert demonstrations as MCAP (default: the paper's 20 box pack/unpack runs; "
    "each task by its registered expert; --task-file: your layout, by the generic expert)",
    configure=_demos_configure,
    run=_demos_run,
)
