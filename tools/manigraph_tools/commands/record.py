"""`manigraph record`: every manigraph/** sample to MCAP, rotated by size and age;
`--recover` finalises a killed recorder's file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.mcap_log import recover_log
from manigraph_shared.service import run_service
from manigraph_tools.recorder import DEFAULT_MAX_BYTES, DEFAULT_MAX_SECONDS, Recorder


def _record_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", type=Path, default=Path("logs"), help="MCAP file or directory"
    )
    parser.add_argument("--flush-interval", type=float, default=0.1, help="seconds (default 0.1)")
    parser.add_argument(
        "--no-foxglove",
        action="store_true",
        help="only the JSON channels: no /foxglove/scene and /foxglove/tf",
    )
    parser.add_argument(
        "--max-bytes",
        type=int,
        default=DEFAULT_MAX_BYTES,
        help=f"start a new file past this size (default {DEFAULT_MAX_BYTES >> 20} MiB)",
    )
    parser.add_argument(
        "--max-seconds",
        type=float,
        default=DEFAULT_MAX_SECONDS,
        help=f"start a new file after this long (default {DEFAULT_MAX_SECONDS:g} s)",
    )
    parser.add_argument(
        "--recover",
        type=Path,
        metavar="FILE",
        help="finalise FILE, left unfinished by a killed recorder, in place; then exit",
    )
    add_bus_arguments(parser)


def _record_run(args: argparse.Namespace) -> int:
    if args.recover is not None:
        kept = recover_log(args.recover)
        print(f"{args.recover}: finalised with {kept} messages", file=sys.stderr)
        return 0
    return run_service(
        lambda bus: Recorder(
            bus,
            args.output,
            args.flush_interval,
            args.max_bytes,
            args.max_seconds,
            foxglove=not args.no_foxglove,
        ),
        bus_config_from_args(args),
    )


command = Command(
    help="record every manigraph/** sample to MCAP (flushed every 100 ms, rotated by size "
    "and age), every robot cell on its own channels (--cell NAME: that cell only); --recover "
    "finalises a killed recorder's file",
    configure=_record_configure,
    run=_record_run,
)
