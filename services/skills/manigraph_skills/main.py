"""``manigraph skills``: entry point."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--driver", default="sim-gripper", help="robot driver (default sim-gripper)"
    )
    parser.add_argument(
        "--workspace",
        default=None,
        help="reachable box xmin,xmax,ymin,ymax,zmin,zmax in metres (robot frame)",
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.service import run_service
    from manigraph_skills.drivers import DRIVERS, create_driver
    from manigraph_skills.service import SkillsService
    from manigraph_skills.workspace import Workspace

    workspace = Workspace.parse(args.workspace) if args.workspace else Workspace()
    if args.driver not in DRIVERS:
        create_driver(args.driver)  # raises the ConfigError naming the choices
    return run_service(
        lambda bus: SkillsService(bus, lambda b: create_driver(args.driver, bus=b), workspace),
        bus_config_from_args(args),
    )


command = Command(
    help="run the skills service (Action -> PickAndPlace)", configure=_configure, run=_run
)
