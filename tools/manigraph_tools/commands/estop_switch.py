"""What ``manigraph stop`` and ``manigraph resume`` share: their flags, and sending the
stop or its release (:mod:`manigraph_tools.estop`)."""

from __future__ import annotations

import argparse
import sys

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_tools.estop import latched, operator, send


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--reason", default="", help="why, for the log and `manigraph status`")
    parser.add_argument(
        "--by", default=None, help="who sends it, for the log and `status` (default: user@host)"
    )
    parser.add_argument(
        "--wait", type=float, default=2.0, help="seconds to wait for skills to acknowledge"
    )
    add_bus_arguments(parser)


def switch(args: argparse.Namespace, engaged: bool) -> int:
    """Publish the stop (``engaged``) or its release; 0 once skills acknowledged it and the
    stack latched it."""
    reason = args.reason or ("manigraph stop" if engaged else "manigraph resume")
    with Bus.open(bus_config_from_args(args, wait_seconds=5.0)) as bus:
        ok = send(bus, engaged, reason, args.wait, by=args.by or operator())
        held = latched(bus, engaged)
    what = "engaged" if engaged else "released"
    latch = (
        "latched by the stack"
        if held
        else "NOT confirmed by the stack's latch (is the router a manigraph router?)"
    )
    if ok:
        print(f"emergency stop {what}, {latch}; skills acknowledged", file=sys.stderr)
        return 0 if held else 1
    print(
        f"emergency stop {what} (published, {latch}), but skills did not acknowledge within "
        f"{args.wait:g} s: is it running?",
        file=sys.stderr,
    )
    return 1
