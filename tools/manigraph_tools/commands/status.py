"""`manigraph status`: the stack at a glance (docs/running.md, "The state of a stack")."""

from __future__ import annotations

import argparse
import time

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_tools import stack_status
from manigraph_tools.commands.common import emit_json

#: How long to wait for the router before saying there is no stack.
CONNECT_SECONDS = 2.0


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--wait",
        type=float,
        default=stack_status.DEFAULT_WAIT,
        help=f"seconds to wait for the services' statuses (default {stack_status.DEFAULT_WAIT:g})",
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    started = time.monotonic()
    config = bus_config_from_args(args, wait_seconds=CONNECT_SECONDS, identity="client")
    # No router there: the bus says so in one line, naming the endpoint (the runtime exit).
    with Bus.open(config) as bus:
        status = stack_status.gather(bus, config, wait=args.wait, started=started)
    if args.json:
        emit_json(status.as_json())
    else:
        print(stack_status.text(status))
    return 0


command = Command(
    help="the stack at a glance: endpoint, cells, security, each service's version and uptime, "
    "the planner's policy and checkpoint, the emergency stop, warnings",
    configure=_configure,
    run=_run,
)
