"""`manigraph router`: a Zenoh router."""

from __future__ import annotations

import argparse
from pathlib import Path

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_tools.estop_keeper import STATE_DIR_ENV
from manigraph_tools.zenoh_router import run_router


def _router_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--state-dir",
        type=Path,
        help="the stack's state directory, where the emergency stop is latched across restarts "
        f"[{STATE_DIR_ENV}; default ~/.local/state/manigraph/<listen endpoint>]",
    )
    add_bus_arguments(parser)


command = Command(
    help="run a Zenoh router (default: listen on tcp/127.0.0.1:7447) and keep the stack's "
    "emergency-stop latch",
    configure=_router_configure,
    run=lambda args: run_router(bus_config_from_args(args, mode="router"), args.state_dir),
)
