"""``manigraph export LOG.mcap --format ros2|lerobot -o DIR``: a log in another ecosystem's
format, and one JSON line saying what was written."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from manigraph_shared.cli import Command
from manigraph_tools.commands.common import emit_json
from manigraph_tools.interop.formats import FORMATS


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", type=Path, help="MCAP log written by manigraph")
    parser.add_argument("--format", required=True, choices=FORMATS.names(), help=FORMATS.describe())
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="folder to write (new, or empty)"
    )
    parser.add_argument(
        "--cell",
        default=None,
        help="the robot cell to export from a log of several ('': the default cell); "
        "default: the log's only cell",
    )


def _run(args: argparse.Namespace) -> int:
    exporter = FORMATS[args.format]
    emit_json(exporter(args.log, args.output, sys.stderr, args.cell))
    return 0


command = Command(
    help="export a log as a ROS 2 bag or a LeRobot dataset", configure=_configure, run=_run
)
