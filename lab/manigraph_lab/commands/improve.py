"""``manigraph improve --policy P --task-file F --rules R --rounds N --episodes M -o P2``:
DAgger with the teacher (:mod:`manigraph_lab.teacher_dagger`, docs/training.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_planner.threads import add_threads_option
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--policy", type=Path, required=True, help="the checkpoint to improve (manigraph train's)"
    )
    parser.add_argument(
        "--task-file", type=Path, required=True, help="the task file its episodes are drawn from"
    )
    parser.add_argument(
        "--rules",
        type=Path,
        required=True,
        help="the rules only the teacher and the judge know (what `demos --rules` was given)",
    )
    parser.add_argument("--rounds", type=int, default=2, help="rounds (default: 2)")
    parser.add_argument(
        "--episodes", type=int, default=10, help="episodes the policy plays per round (default: 10)"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=3000,
        help="seed of round 1's first episode; round r goes on from seed + (r - 1) * episodes "
        "(default: 3000, apart from the demonstrations' 0+)",
    )
    parser.add_argument("--device", default="cpu", help="where to retrain: cpu, cuda or cuda:N")
    add_threads_option(parser)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        help="the improved checkpoint (.pt); each round's labels go beside it as "
        "<name>.round<N>.mcap",
    )


def _run(args: argparse.Namespace) -> int:
    from manigraph_lab.task_files import checked_files
    from manigraph_lab.teacher_dagger import ImprovePlan, improve
    from manigraph_planner.threads import use_threads
    from manigraph_shared.results import checkpoint_field, rounded
    from manigraph_tools.episode_plan import EpisodeOptions

    use_threads(args.threads)
    episodes = EpisodeOptions(task_file=args.task_file, rules=args.rules)
    # A bad file, or rules that do not fit the task file, stop here naming the file and field.
    task_file, _, rules = checked_files(episodes)
    assert task_file is not None and rules is not None
    plan = ImprovePlan(
        policy=args.policy,
        task_file=task_file,
        task_file_name=episodes.label(),
        rules=rules,
        rules_name=str(args.rules),
        output=args.output,
        rounds=args.rounds,
        episodes=args.episodes,
        seed=args.seed,
        device=args.device,
        threads=args.threads,
    )
    summary = improve(plan, sys.stderr)
    print(json.dumps(rounded({**checkpoint_field(args.output), **summary})))
    return 0


command = Command(
    help="DAgger with the teacher: play a policy on a task file, have the rules' teacher "
    "label every scene it visited, add the labels to its data and retrain, N rounds",
    configure=_configure,
    run=_run,
)
