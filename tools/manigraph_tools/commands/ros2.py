"""``manigraph ros2``: the live bus republished for ROS 2
(:mod:`manigraph_tools.interop.ros2_bridge`)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.options import add_option_arguments, options_from_args
from manigraph_shared.service import run_service
from manigraph_tools.interop.ros2_bridge import Ros2Bridge, Ros2BridgeOptions


def _configure(parser: argparse.ArgumentParser) -> None:
    add_option_arguments(parser, Ros2BridgeOptions)
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    options = options_from_args(Ros2BridgeOptions, args)
    return run_service(lambda bus: Ros2Bridge(bus, options), bus_config_from_args(args))


command = Command(
    help="republish joint states, /tf and the scene markers for ROS 2 (rmw_zenoh's format)",
    configure=_configure,
    run=_run,
)
