"""``manigraph select``: keep the candidate checkpoint with the best validation success
(:mod:`manigraph_lab.selection`), its cells run as Ray tasks (``--workers``,
``--ray-address``, ``--no-ray``)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_lab.sweep import SweepOptions, add_sweep_options
from manigraph_planner.threads import add_threads_option, use_threads
from manigraph_shared.cli import Command


def _select_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("checkpoints", type=Path, nargs="+", help="candidate checkpoints")
    parser.add_argument("-o", "--output", type=Path, required=True, help="where the kept one goes")
    parser.add_argument("--episodes", type=int, default=30, help="validation episodes per cell")
    parser.add_argument("--table", type=Path, help="also write the Markdown table here")
    add_threads_option(parser)
    add_sweep_options(parser)


def _select_run(args: argparse.Namespace) -> int:
    from manigraph_lab.selection import select_checkpoint
    from manigraph_planner.policies import load_policy
    from manigraph_shared.results import checkpoint_field, rounded

    sweep = SweepOptions.from_args(args)
    for candidate in args.checkpoints:  # a file that is no checkpoint: one line, before any cell
        load_policy(str(candidate))
    use_threads(args.threads)
    chosen, table = select_checkpoint(
        args.checkpoints, args.output, args.episodes, progress=sys.stderr, sweep=sweep
    )
    if args.table is not None:
        args.table.parent.mkdir(parents=True, exist_ok=True)
        args.table.write_text(table)
    print(table)
    kept = {**checkpoint_field(args.output), "kept": str(chosen.path), **chosen.scores}
    print(json.dumps(rounded(kept)))
    return 0


command = Command(
    help="keep the candidate checkpoint with the best validation success (seeds 1000+)",
    configure=_select_configure,
    run=_select_run,
)
