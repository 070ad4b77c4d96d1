"""The ``manigraph`` command. Subcommands are registered by each installed package.

A package adds a subcommand with an entry point in the ``manigraph.commands`` group pointing at
a :class:`Command`; an image that installs only the sim service therefore has ``manigraph sim``
and the shared tools, and nothing it cannot run.

A command that fails prints one line, ``manigraph <command>: <why>``, and exits with the status
of that kind of failure (usage 2, configuration 78, runtime 1: ``manigraph_shared.errors``).
An unknown flag is answered with the usage of the subcommand it was given to.
"""

from __future__ import annotations

import argparse
import errno
import logging
import os
import signal
import sys
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import entry_points

from manigraph_shared.errors import (
    CONFIG_EXIT_CODE,
    INTERRUPTED_EXIT_CODE,
    RUNTIME_EXIT_CODE,
    ManigraphError,
)

GROUP = "manigraph.commands"
#: ``OSError``s that mean a path given is wrong (configuration), not that the machine failed
#: while it ran (a full disk: runtime).
PATH_ERRORS = frozenset(
    {
        errno.ENOENT,
        errno.ENOTDIR,
        errno.EISDIR,
        errno.EEXIST,
        errno.EACCES,
        errno.EPERM,
        errno.EROFS,
    }
)


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


def _chosen_command(argv: list[str], names: set[str]) -> str | None:
    """The subcommand ``argv`` names, if it names one: only its entry point then needs
    loading (``manigraph router`` should not import torch because the planner is installed)."""
    tokens = iter(argv)
    for token in tokens:
        if token == "--log-level":
            next(tokens, None)
        elif not token.startswith("-"):
            return token if token in names else None
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser of every installed subcommand; given ``argv`` that names one, of it alone."""
    entries = {entry.name: entry for entry in entry_points(group=GROUP)}
    chosen = _chosen_command(argv, set(entries)) if argv is not None else None
    parser = argparse.ArgumentParser(
        prog="manigraph",
        description="Learn long-horizon manipulation policies with GNNs; run them over Zenoh.",
    )
    parser.add_argument("--log-level", help="DEBUG, INFO, WARNING (env MANIGRAPH_LOG_LEVEL)")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in [chosen] if chosen else sorted(entries):
        entry = entries[name]
        command: Command = entry.load()
        sub = subparsers.add_parser(entry.name, help=command.help, description=command.help)
        command.configure(sub)
        sub.set_defaults(run=command.run)
    return parser


def _subparsers_action(parser: argparse.ArgumentParser) -> argparse._SubParsersAction | None:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return None


def subcommand_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The parser of each subcommand ``parser`` holds, by name."""
    action = _subparsers_action(parser)
    return dict(action.choices) if action is not None else {}


def parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """``argv`` parsed; an argument no parser knows is refused by the parser of the
    (innermost) subcommand given, so the usage printed is that subcommand's (argparse's top
    level would print its own)."""
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        chosen = parser
        while (action := _subparsers_action(chosen)) is not None:
            name = getattr(args, action.dest, None)
            if name not in action.choices:
                break
            chosen = action.choices[name]
        chosen.error(f"unrecognized arguments: {' '.join(unknown)}")
    return args


def one_line(error: BaseException) -> str:
    """``error``'s message on one line (a refusal is one line, whatever raised it)."""
    text = " ".join(part.strip() for part in str(error).splitlines() if part.strip())
    return text or type(error).__name__


def interrupted_exit_code(interrupt: KeyboardInterrupt) -> int:
    """The exit status of a command a stop signal ended: 130 for Ctrl-C (SIGINT), and 128 + the
    signal's number for another one a command turned into ``KeyboardInterrupt(name)`` (``up``
    stopped by SIGTERM: 143; a closing terminal, SIGHUP: 129), as a shell reports them."""
    try:
        return 128 + int(signal.Signals[str(interrupt)])
    except KeyError:
        return INTERRUPTED_EXIT_CODE


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser(argv)
    args = parse(parser, argv)
    setup_logging(args.log_level)
    try:
        return int(args.run(args) or 0)
    except ManigraphError as exc:
        print(f"manigraph {args.command}: {one_line(exc)}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt as interrupt:
        return interrupted_exit_code(interrupt)
    except OSError as exc:  # a path given that cannot be read or written, most often
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"manigraph {args.command}: {where}{exc.strerror or one_line(exc)}", file=sys.stderr)
        return CONFIG_EXIT_CODE if exc.errno in PATH_ERRORS else RUNTIME_EXIT_CODE
    except Exception as exc:  # a bug, or a library's error nothing above names: still one line
        if logging.getLogger().isEnabledFor(logging.DEBUG):
            raise
        print(
            f"manigraph {args.command}: internal error: {type(exc).__name__}: {one_line(exc)} "
            "(--log-level DEBUG shows where)",
            file=sys.stderr,
        )
        return RUNTIME_EXIT_CODE


if __name__ == "__main__":
    sys.exit(main())
