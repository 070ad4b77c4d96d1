"""``manigraph skills``: entry point."""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--driver",
        default="sim-gripper",
        help="robot driver (default sim-gripper); auto: the one the sim backend named by "
        "MANIGRAPH_SIM_BACKEND (default geometric) offers what it needs, from the manifests",
    )
    parser.add_argument(
        "--workspace",
        default=None,
        help="reachable box xmin,xmax,ymin,ymax,zmin,zmax in metres (robot frame)",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="plan, validate and log every trajectory, move nothing (driver franka)",
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.service import run_service
    from manigraph_skills.drivers import DRIVERS, create_driver
    from manigraph_skills.service import SkillsService
    from manigraph_skills.workspace import Workspace

    workspace = Workspace.parse(args.workspace) if args.workspace else Workspace()
    if args.driver == "auto":
        args.driver = auto_driver(os.environ)
    if args.driver not in DRIVERS:
        create_driver(args.driver)  # raises the ConfigError naming the choices
    options: dict[str, object] = {}
    if args.dry_run:
        if not DRIVERS[args.driver].supports_dry_run:  # type: ignore[attr-defined]
            dry = sorted(n for n, d in DRIVERS.items() if getattr(d, "supports_dry_run", False))
            raise ConfigError("dry_run", f"driver '{args.driver}' has none (only {', '.join(dry)})")
        options["dry_run"] = True
    return run_service(
        lambda bus: SkillsService(
            bus, lambda b: create_driver(args.driver, bus=b, **options), workspace
        ),
        bus_config_from_args(args),
    )


def auto_driver(environ: Mapping[str, str]) -> str:
    """``--driver auto``: the driver for the sim backend ``MANIGRAPH_SIM_BACKEND`` names."""
    from manigraph_shared.manifest import driver_for_backend

    return driver_for_backend(environ.get("MANIGRAPH_SIM_BACKEND", "geometric").strip())


command = Command(
    help="run the skills service (Action -> PickAndPlace)", configure=_configure, run=_run
)
