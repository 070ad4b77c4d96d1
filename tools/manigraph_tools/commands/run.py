"""`manigraph run`: seeded episodes on an already running stack."""

from __future__ import annotations

import argparse

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_tools.commands.common import emit_json, wait_services
from manigraph_tools.commands.episode_flags import episode_arguments, plan_from_args
from manigraph_tools.episodes import raise_if_aborted, run_episodes


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


command = Command(
    help="run seeded episodes on an already running stack (--cell NAME: in that robot cell); "
    "last line: one JSON object",
    configure=_run_configure,
    run=_run_run,
)
