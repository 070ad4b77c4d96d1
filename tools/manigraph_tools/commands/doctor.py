"""`manigraph doctor`: which services are alive, missing or stalled; an engaged e-stop."""

from __future__ import annotations

import argparse
import sys

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_tools import service_health
from manigraph_tools.commands.common import emit_json


def _doctor_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--expect",
        nargs="+",
        default=list(service_health.DEFAULT_STACK),
        help=f"services that must be alive (default: {' '.join(service_health.DEFAULT_STACK)})",
    )
    parser.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for answers")
    parser.add_argument(
        "--stall-seconds",
        type=float,
        default=service_health.DEFAULT_STALL_SECONDS,
        help="an alive service without a heartbeat for this long is STALLED "
        f"(default {service_health.DEFAULT_STALL_SECONDS:g}; 0: liveliness only)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_bus_arguments(parser)


def _doctor_run(args: argparse.Namespace) -> int:
    config = bus_config_from_args(args, wait_seconds=args.timeout)
    try:
        bus = Bus.open(config)
    except Exception as exc:  # no router at all: everything is missing
        if not args.json:  # one line, as every client says it (the table would add nothing)
            print(f"manigraph doctor: {exc}", file=sys.stderr)
            return 1
        health = service_health.Health(list(args.expect), list(args.expect))
    else:
        with bus:
            health = service_health.check(bus, args.expect, args.timeout, args.stall_seconds)
    if args.json:
        emit_json(health.as_json())
    else:
        print(service_health.table(health, args.expect))
    return 1 if service_health.unhealthy(health, args.expect) else 0


command = Command(
    help="list which services are alive, missing or stalled, and an engaged emergency stop "
    "(exit 1 if any expected one is missing or stalled)",
    configure=_doctor_configure,
    run=_doctor_run,
)
