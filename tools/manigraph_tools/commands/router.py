"""`manigraph router`: a Zenoh router."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_tools.router import run_router


def _router_configure(parser: argparse.ArgumentParser) -> None:
    add_bus_arguments(parser)


router_command = Command(
    help="run a Zenoh router (default: listen on tcp/127.0.0.1:7447)",
    configure=_router_configure,
    run=lambda args: run_router(bus_config_from_args(args, mode="router")),
)
