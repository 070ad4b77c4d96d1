"""`manigraph run`: seeded episodes on an already running stack."""

from __future__ import annotations

import argparse
import secrets
import time

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.options import add_option_arguments, options_from_args
from manigraph_tools.commands.common import emit_json, wait_services
from manigraph_tools.episode_plan import EpisodeOptions, EpisodePlan
from manigraph_tools.episodes import raise_if_aborted, run_episodes


def episode_arguments(parser: argparse.ArgumentParser) -> None:
    add_option_arguments(parser.add_argument_group("episodes"), EpisodeOptions)


def plan_from_args(args: argparse.Namespace, episodes: int) -> EpisodePlan:
    options = options_from_args(EpisodeOptions, args)
    # Seconds alone repeat: two runs started in one second (cells driven side by side) would
    # give their episodes the same ids, and the logs would mix them.
    run_id = f"{options.label()}-{int(time.time())}-{secrets.token_hex(2)}"
    return options.plan(episodes, run_id=run_id)


def _run_configure(parser: argparse.ArgumentParser) -> None:
    episode_arguments(parser)
    add_bus_arguments(parser)


def _run_run(args: argparse.Namespace) -> int:
    plan = plan_from_args(args, args.episodes or 1)  # a bad option stops here, before any waiting
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        # Right after `docker compose up -d` the planner may still be importing torch: at
        # load 33 on 2 cores it was not alive 90 s after `up -d` (as `up`, wait 180 s).
        wait_services(bus, ["sim", "planner", "skills"], timeout=180.0)
        summary = run_episodes(bus, plan)
    emit_json(summary, readable=not args.json)
    if summary.get("interrupted"):  # Ctrl-C: the episodes so far, then the status it means
        raise KeyboardInterrupt
    # An engaged emergency stop (1), a planner that cannot decide (78): the episodes asked
    # for did not run; one line, naming why.
    raise_if_aborted(summary)
    return 0


run_command = Command(
    help="run seeded episodes on an already running stack (--cell NAME: in that robot cell); "
    "last line: one JSON object",
    configure=_run_configure,
    run=_run_run,
)
