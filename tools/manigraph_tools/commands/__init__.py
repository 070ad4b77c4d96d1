"""The subcommands ``manigraph_tools`` registers (``manigraph.commands`` entry points), one
module each: router, record, replay, doctor, keys, run, status, up."""

from manigraph_tools.commands.doctor import doctor_command
from manigraph_tools.commands.keys import keys_command
from manigraph_tools.commands.record import record_command
from manigraph_tools.commands.replay import replay_command
from manigraph_tools.commands.router import router_command
from manigraph_tools.commands.run import run_command
from manigraph_tools.commands.status import status_command
from manigraph_tools.commands.up import up_command

__all__ = [
    "doctor_command",
    "keys_command",
    "record_command",
    "replay_command",
    "router_command",
    "run_command",
    "status_command",
    "up_command",
]
