"""``manigraph perception``: camera + ArUco markers -> Scene (hardware side).

The camera pipeline arrives with the perception issue; until then the command refuses to
start with a clear message instead of pretending to observe anything.
"""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--camera", default=None, help="camera device or stream URL")
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    raise ConfigError(
        "camera",
        "the ArUco perception pipeline is not implemented yet; run the sim service "
        "(or `manigraph replay` a recorded log) as the Scene source",
    )


command = Command(
    help="run camera perception (not implemented yet: fails clearly)",
    configure=_configure,
    run=_run,
)
