"""``manigraph skills``: entry point.

The driver's option flags come from its registered options
(``manigraph_skills.drivers.registry``); a flag the chosen driver does not take stops start-up
with a ``ConfigError`` naming it. ``--driver auto`` takes the driver whose needs the sim
backend named by ``MANIGRAPH_SIM_BACKEND`` offers (from the manifests), so compose switches
worlds with one variable.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_skills.drivers.registry import DRIVERS


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--driver",
        default="sim-gripper",
        help=f"robot driver (default: sim-gripper; auto: the one the sim backend named by "
        f"MANIGRAPH_SIM_BACKEND needs); {DRIVERS.describe()}",
    )
    parser.add_argument(
        "--workspace",
        default=None,
        help="reachable box xmin,xmax,ymin,ymax,zmin,zmax in metres (robot frame)",
    )
    DRIVERS.add_arguments(parser.add_argument_group("driver options"))
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.service import run_service
    from manigraph_shared.workspace import Workspace
    from manigraph_skills.service import SkillsService

    name = auto_driver(os.environ) if args.driver == "auto" else args.driver
    workspace = Workspace.parse(args.workspace) if args.workspace else Workspace()
    options = DRIVERS.options_from_args(name, args)
    driver = DRIVERS[name]
    return run_service(
        lambda bus: SkillsService(bus, lambda b: driver.from_options(b, options), workspace),
        bus_config_from_args(args),
    )


def auto_driver(environ: Mapping[str, str]) -> str:
    """``--driver auto``: the driver for the sim backend ``MANIGRAPH_SIM_BACKEND`` names."""
    from manigraph_shared.manifest import driver_for_backend

    return driver_for_backend(environ.get("MANIGRAPH_SIM_BACKEND", "geometric").strip())


command = Command(
    help="run the skills service (Action -> PickAndPlace)", configure=_configure, run=_run
)
