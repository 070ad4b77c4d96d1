"""The codes of a manigraph LeRobot dataset, stated once for its writer and its reader.

``manigraph export --format lerobot`` (``manigraph_tools.interop``) writes them and
``manigraph train DIR`` (``manigraph_training.lerobot_source``) reads them back; tools
and services do not import each other, so what both must agree on lives here
(docs/interop.md, "LeRobot datasets").
"""

from __future__ import annotations

#: The robot of every manigraph cell (``info.json``'s ``robot_type``); a dataset naming
#: another is refused on import.
ROBOT_TYPE = "panda"
#: Prefix of the per-node observation columns (``observation.nodes.position``, ...).
NODES = "observation.nodes"
#: ``observation.nodes.category`` codes (index in this tuple); padding rows hold -1.
NODE_CATEGORIES = (
    "object:cover",
    "object:block",
    "object:plate",
    "object:bowl",
    "goal:block",
    "goal:cover",
    "goal:plate",
    "goal:bowl",
    "rack",
)
#: ``action``'s tray column: index in this tuple (the contract's ``TrayAction`` values).
TRAY_ACTIONS = ("none", "toggle_top", "toggle_bottom")
