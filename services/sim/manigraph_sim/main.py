"""``manigraph sim``: entry point (imports stay lazy so ``manigraph --help`` is fast)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend", default="geometric", help="sim backend: geometric (default) or physics"
    )
    parser.add_argument("--publish-hz", type=float, default=10.0, help="scene rate (default 10)")
    parser.add_argument(
        "--goal-tolerance", type=float, default=0.01, help="metres from a goal that fill it"
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.service import run_service
    from manigraph_sim import geometric  # noqa: F401  (registers the backend)
    from manigraph_sim.backend import create_backend
    from manigraph_sim.service import SimService

    if args.publish_hz <= 0 or args.publish_hz > 1000:
        raise ConfigError("publish-hz", "must be in (0, 1000]")
    backend = create_backend(args.backend, goal_tolerance=args.goal_tolerance)
    return run_service(
        lambda bus: SimService(bus, backend, args.publish_hz), bus_config_from_args(args)
    )


command = Command(help="run the sim service (publishes Scene)", configure=_configure, run=_run)
