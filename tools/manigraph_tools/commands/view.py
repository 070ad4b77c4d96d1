"""``manigraph view``: the live bus in Foxglove (:mod:`manigraph_tools.foxglove_view`)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError
from manigraph_shared.service import run_service
from manigraph_tools.foxglove_layout import layout_json
from manigraph_tools.foxglove_view import DEFAULT_HOST, DEFAULT_PORT, FoxgloveView


def _view_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default=DEFAULT_HOST, help=f"bind address ({DEFAULT_HOST})")
    parser.add_argument(
        "--ws-port",
        type=int,
        default=DEFAULT_PORT,
        help=f"port of the WebSocket Foxglove connects to (default {DEFAULT_PORT}); "
        "--port is the stack's router port, as for every client",
    )
    parser.add_argument(
        "--print-layout",
        action="store_true",
        help="print a Foxglove layout for manigraph (3D scene, decision, why) and exit",
    )
    add_bus_arguments(parser)


def _view_run(args: argparse.Namespace) -> int:
    if args.print_layout:
        print(layout_json(), end="")
        return 0
    if not 0 <= args.ws_port <= 65535:
        raise ConfigError("ws-port", f"{args.ws_port} is not in 0..65535")
    return run_service(
        lambda bus: FoxgloveView(bus, args.host, args.ws_port), bus_config_from_args(args)
    )


command = Command(
    help="serve the live bus to Foxglove (WebSocket, default ws://127.0.0.1:8765)",
    configure=_view_configure,
    run=_view_run,
)
