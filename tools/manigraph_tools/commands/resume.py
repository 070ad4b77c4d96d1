"""``manigraph resume``: release the emergency stop (:mod:`manigraph_tools.estop`)."""

from __future__ import annotations

from manigraph_shared.cli import Command
from manigraph_tools.commands.estop_switch import configure, switch

command = Command(
    help="release the emergency stop: skills accepts actions again",
    configure=configure,
    run=lambda args: switch(args, engaged=False),
)
