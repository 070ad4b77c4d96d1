"""The subcommands ``manigraph_tools`` registers (``manigraph.commands`` entry points), one
module each: router, record, replay, doctor, keys, run, status, up.

Each is imported when it is asked for, not with the package: ``manigraph status`` should not
wait for the recorder's, the replayer's and ``up``'s imports (a third of a second, more on a
busy machine) before it can answer."""

from __future__ import annotations

from importlib import import_module
from typing import Any

#: Each command's object -> the module of this package that defines it.
_MODULES = {
    "doctor_command": "doctor",
    "keys_command": "keys",
    "record_command": "record",
    "replay_command": "replay",
    "router_command": "router",
    "run_command": "run",
    "status_command": "status",
    "up_command": "up",
}

__all__ = sorted(_MODULES)


def __getattr__(name: str) -> Any:
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{module}"), name)
