"""The lab's subcommands: ``demos``, ``eval``, ``suite`` and ``select`` (training lives with the
planner). Long work shows a progress bar on stderr when stderr is a terminal (and ``eval``
not given ``--json``); piped or redirected, only results are printed. ``suite`` and ``select``
run their cells as Ray tasks (``--workers``, ``--ray-address``, ``--no-ray``)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from manigraph_lab.sweep import SweepOptions, add_sweep_options
from manigraph_planner.threads import add_threads_option, use_threads
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError
from manigraph_shared.options import (
    Interval,
    Options,
    add_option_arguments,
    option,
    options_from_args,
)

if TYPE_CHECKING:
    from manigraph_lab.demos import DemoProtocol
    from manigraph_tools.episode_plan import EpisodeOptions


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
    from manigraph_lab.demos import DemoProtocol, record_demos

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
    text, blocks, rules_text = _checked_files(episodes)
    assert text is not None
    return replace(
        protocol,
        blocks=(blocks,),
        task_file=text,
        task_file_name=episodes.label(),
        rules=rules_text,
    )


def _checked_files(episodes: EpisodeOptions) -> tuple[str | None, int, str | None]:
    """The task file's text and blocks, and the rules file's text, each checked here (a bad
    one stops the command naming the file, the line and the field); no task file: None, the
    ``--blocks`` asked for, None."""
    task_file = episodes.task_text()
    rules = episodes.rules_text()
    if task_file is None:
        return None, episodes.blocks, None
    from manigraph_sim.families.blocks.rules_file import parse_rules_file
    from manigraph_sim.families.blocks.task_file import parse_task_file

    blocks = parse_task_file(task_file, str(episodes.task_file)).blocks
    if rules is not None:
        parse_rules_file(rules, task_file, str(episodes.rules))
    return task_file, blocks, rules


demos_command = Command(
    help="record expert demonstrations as MCAP (default: the paper's 20 box pack/unpack runs; "
    "each task by its registered expert; --task-file: your layout, by the generic expert)",
    configure=_demos_configure,
    run=_demos_run,
)


@dataclass(frozen=True)
class EvalOptions(Options):
    policy: str = option("expert", help="policy name or checkpoint file")
    noise: float = option(0.0, help="observation noise sigma", within=Interval(0, None), unit="m")
    accepts_filter: Literal["on", "off"] = option(
        "on",
        help="a policy learned from a task file takes only pairs whose goal accepts the object "
        "(on); off: the network's own choice, to measure what it learned (docs/training.md)",
    )


def _eval_configure(parser: argparse.ArgumentParser) -> None:
    from manigraph_tools.episode_plan import EpisodeOptions

    add_option_arguments(parser, EvalOptions)
    # The episode flags of run and up; every episode runs to its end in-process, no timeout.
    episodes = parser.add_argument_group("episodes")
    add_option_arguments(episodes, EpisodeOptions, exclude=["episodes", "timeout", "stall_timeout"])
    episodes.add_argument(
        "--episodes",
        type=int,
        default=100,
        help="episodes to play, seeded --seed, --seed + 1, ... (default: 100)",
    )


def _eval_run(args: argparse.Namespace) -> int:
    from manigraph_lab.evaluate import EvalSpec, evaluate
    from manigraph_planner.policies import POLICIES, load_policy
    from manigraph_planner.policies.teacher_rules import TEACHERS, with_rules
    from manigraph_shared.results import checkpoint_field, rounded
    from manigraph_tools.episode_plan import EpisodeOptions

    options = options_from_args(EvalOptions, args)
    episodes = options_from_args(EpisodeOptions, args)
    # A bad file stops here, naming the file, the line and the field.
    task_file, blocks, rules = _checked_files(episodes)
    spec = EvalSpec(
        "file" if task_file else episodes.task,
        blocks,
        episodes.stacks,
        episodes.episodes or 1,
        episodes.seed,
        options.noise,
        task_file,
        episodes.label() if task_file is not None else None,
        objects=episodes.objects,
        preference=episodes.preference,
        rules=rules,
    )
    progress = None if episodes.json else sys.stderr
    policy = load_policy(options.policy, accepts_filter=options.accepts_filter)
    if rules is not None and options.policy in TEACHERS:  # the teacher is told them
        policy = with_rules(policy, rules, str(episodes.rules))
    checkpoint = None if options.policy in POLICIES else checkpoint_field(options.policy)
    summary = rounded(evaluate(policy, spec, progress, checkpoint))
    assert isinstance(summary, dict)
    if policy.accepts_filter is not None:  # what was judged: the network alone, or filtered
        summary["accepts_filter"] = "on" if policy.accepts_filter else "off"
    if episodes.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            print(f"{key:>22}: {value}")
    return 0


eval_command = Command(
    help="evaluate a policy on seeded episodes in one process (--json: one JSON line)",
    configure=_eval_configure,
    run=_eval_run,
)


def _suite_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--out",
        type=Path,
        default=Path("results"),
        help="folder of the table, the plot, suite.json and the checkpoints (default: results)",
    )
    parser.add_argument(
        "--archs",
        nargs="+",
        default=["gcn", "sage", "gated", "gat"],
        metavar="ARCH",
        help="architectures to train and evaluate (default: gcn sage gated gat)",
    )
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=[0, 1, 2],
        metavar="SEED",
        help="training seeds, one policy each (default: 0 1 2)",
    )
    parser.add_argument("--episodes", type=int, default=100, help="episodes per table cell")
    parser.add_argument("--curve-episodes", type=int, default=50, help="episodes per K in the plot")
    parser.add_argument(
        "--epochs", type=int, default=150, help="training epochs per policy (default: 150)"
    )
    parser.add_argument(
        "--eval-seed",
        type=int,
        default=0,
        help="first episode seed of the table (reported: 0; choosing a recipe: 1000+)",
    )
    add_threads_option(parser)
    add_sweep_options(parser)


def _suite_run(args: argparse.Namespace) -> int:
    from manigraph_lab.suite import run_suite

    sweep = SweepOptions.from_args(args)
    use_threads(args.threads)
    run_suite(
        args.out,
        args.archs,
        args.seeds,
        args.episodes,
        args.curve_episodes,
        args.epochs,
        progress=sys.stderr,
        eval_seed=args.eval_seed,
        sweep=sweep,
    )
    print((args.out / "generalization.md").read_text())
    return 0


suite_command = Command(
    help="reproduce the paper's generalization table and success-vs-K plot (all archs, seeds)",
    configure=_suite_configure,
    run=_suite_run,
)


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


select_command = Command(
    help="keep the candidate checkpoint with the best validation success (seeds 1000+)",
    configure=_select_configure,
    run=_select_run,
)
