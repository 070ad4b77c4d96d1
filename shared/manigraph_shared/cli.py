"""The ``manigraph`` command. Subcommands are registered by each installed package.

A package adds a subcommand with an entry point in the ``manigraph.commands`` group pointing at
a :class:`Command`; an image that installs only the sim service therefore has ``manigraph sim``
and the shared tools, and nothing it cannot run.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import entry_points

from manigraph_shared.errors import ManigraphError

GROUP = "manigraph.commands"


@dataclass(frozen=True)
class Command:
    help: str
    configure: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


def setup_logging(level: str | None = None) -> None:
    logging.basicConfig(
        level=(level or os.environ.get("MANIGRAPH_LOG_LEVEL", "INFO")).upper(),
        format="%(asctime)s.%(msecs)03d %(levelname)-5s %(name)s: %(message)s",
        datefmt="%H:%M:%S",
        stream=sys.stderr,
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="manigraph",
        description="Learn long-horizon manipulation policies with GNNs; run them over Zenoh.",
    )
    parser.add_argument("--log-level", help="DEBUG, INFO, WARNING (env MANIGRAPH_LOG_LEVEL)")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for entry in sorted(entry_points(group=GROUP), key=lambda e: e.name):
        command: Command = entry.load()
        sub = subparsers.add_parser(entry.name, help=command.help, description=command.help)
        command.configure(sub)
        sub.set_defaults(run=command.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging(args.log_level)
    try:
        return int(args.run(args) or 0)
    except ManigraphError as exc:
        print(f"manigraph {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
