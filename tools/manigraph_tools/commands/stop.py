"""``manigraph stop``: the emergency stop from the command line (:mod:`manigraph_tools.estop`)."""

from __future__ import annotations

from manigraph_shared.cli import Command
from manigraph_tools.commands.estop_switch import configure, switch

command = Command(
    help="emergency stop: halt the robot now and refuse every action until `manigraph resume`",
    configure=configure,
    run=lambda args: switch(args, engaged=True),
)
