"""``manigraph demo-ui``: teach the robot by pointing and clicking (docs/demo-ui.md)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.options import add_option_arguments, options_from_args
from manigraph_shared.service import run_service


def _configure(parser: argparse.ArgumentParser) -> None:
    from manigraph_tools.click_page.service import DemoUiOptions

    add_option_arguments(parser, DemoUiOptions)
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_tools.click_page.service import DemoUiOptions, DemoUiService

    options = options_from_args(DemoUiOptions, args)  # a bad flag stops here, naming it
    return run_service(lambda bus: DemoUiService(bus, options), bus_config_from_args(args))


command = Command(
    help="serve the point-and-click demonstration page on a running stack without a planner "
    "(manigraph up --policy human starts both); demonstrations go to MCAP for manigraph train",
    configure=_configure,
    run=_run,
)
