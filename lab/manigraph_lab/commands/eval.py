"""``manigraph eval``: a policy on seeded episodes in one process
(:mod:`manigraph_lab.evaluate`); long work shows a progress bar on stderr when stderr is a
terminal and ``--json`` is not given."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from typing import Literal

from manigraph_lab.task_files import checked_files
from manigraph_shared.cli import Command
from manigraph_shared.options import (
    Interval,
    Options,
    add_option_arguments,
    option,
    options_from_args,
)

#: ``--policy``'s default: each episode's task family's expert (the block family's is named
#: so; a shelf or dishwasher episode is played by that family's own).
FAMILY_EXPERTS = "expert"


@dataclass(frozen=True)
class EvalOptions(Options):
    policy: str = option(
        FAMILY_EXPERTS,
        help=f"policy name or checkpoint file ({FAMILY_EXPERTS}: each task family's expert)",
    )
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
    from manigraph_lab.demo_recording import family_experts
    from manigraph_lab.evaluate import EvalSpec, evaluate
    from manigraph_planner.policies import POLICIES, load_policy
    from manigraph_planner.policies.teacher_rules import TEACHERS, with_rules
    from manigraph_shared.results import checkpoint_field, rounded
    from manigraph_tools.episode_plan import EpisodeOptions

    options = options_from_args(EvalOptions, args)
    episodes = options_from_args(EpisodeOptions, args)
    # A bad file stops here, naming the file, the line and the field.
    task_file, blocks, rules = checked_files(episodes)
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
    # The default: each episode is played by its family's expert (the teacher told the rules).
    player = (
        family_experts(rules, str(episodes.rules)) if options.policy == FAMILY_EXPERTS else policy
    )
    summary = rounded(evaluate(player, spec, progress, checkpoint))
    assert isinstance(summary, dict)
    if policy.accepts_filter is not None:  # what was judged: the network alone, or filtered
        summary["accepts_filter"] = "on" if policy.accepts_filter else "off"
    if episodes.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            print(f"{key:>22}: {value}")
    return 0


command = Command(
    help="evaluate a policy on seeded episodes in one process (--json: one JSON line)",
    configure=_eval_configure,
    run=_eval_run,
)
