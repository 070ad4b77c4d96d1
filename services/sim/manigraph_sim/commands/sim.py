"""``manigraph sim``: entry point (imports stay lazy so ``manigraph --help`` is fast).

Every backend option flag comes from the backend's registered options
(``manigraph_sim.backends``); a flag the chosen backend does not take stops start-up with a
``ConfigError`` naming it.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.options import Interval, Options, add_option_arguments, option
from manigraph_sim.backends import BACKENDS


@dataclass(frozen=True)
class SimServiceOptions(Options):
    publish_hz: float = option(
        10.0, help="scene rate", within=Interval(0, 1000, low_open=True), unit="Hz"
    )
    scenes: bool = option(
        True,
        help="publish ground-truth scenes (--no-scenes with --camera: perception is the Scene "
        "source and the sim only referees)",
    )
    plays: str | None = option(
        None,
        help="the task file this stack plays (up --task-file passes it): a reset without a task "
        "file is refused, naming it, instead of playing a registered task",
    )


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend",
        default="geometric",
        help=f"sim backend (default: geometric); {BACKENDS.describe()}",
    )
    add_option_arguments(parser, SimServiceOptions)
    BACKENDS.add_arguments(parser.add_argument_group("backend options"))
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.options import options_from_args
    from manigraph_shared.service import run_service
    from manigraph_sim.service import SimService

    service = options_from_args(SimServiceOptions, args)
    options = BACKENDS.options_from_args(args.backend, args)
    if not service.scenes and not getattr(options, "camera", False):
        raise ConfigError("no-scenes", "without --camera nothing would observe the world")
    _refuse_rendering_without_vulkan(options)  # before SAPIEN is imported
    backend = BACKENDS[args.backend].from_options(options)
    camera_hz = options.camera_hz if getattr(options, "camera", False) else 0.0
    return run_service(
        lambda bus: SimService(
            bus,
            backend,
            service.publish_hz,
            scenes=service.scenes,
            camera_hz=camera_hz,
            plays=service.plays,
        ),
        bus_config_from_args(args),
    )


command = Command(help="run the sim service (publishes Scene)", configure=_configure, run=_run)


def _refuse_rendering_without_vulkan(options: object) -> None:
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.preflight import vulkan_problem

    for field, need in (("camera", "the rendered camera"), ("video", "the episode video")):
        if getattr(options, field, None):
            problem = vulkan_problem(need)
            if problem:
                raise ConfigError(field, problem)
