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
#: ``observation.nodes.category`` codes (index in this tuple); padding rows hold -1. An
#: entry without ``:`` is a fixture: :data:`FIXTURE` for every fixture written since contract
#: v4, its kind, state and size in the :data:`FIXTURES` column; ``rack``, the one kind datasets
#: of contract version 3 wrote by name (state ``open`` only, in ``observation.nodes.open``).
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
    "fixture",
)
#: The category of a fixture of any kind (its kind in the :data:`FIXTURES` column).
FIXTURE = "fixture"
#: Per node, a JSON list: a fixture's ``{"kind", "state", "size"}`` (``size`` null where its
#: family gives none), null for an object or a goal. Absent from datasets of contract v3.
FIXTURES = f"{NODES}.fixtures"
#: ``action``'s family-action column: index in this tuple (``Action.family_action``; 0: none,
#: a pick and place). The object and goal columns name the fixture it acts on. Datasets of
#: contract version 3 wrote 1 and 2 for the two racks' toggles: both read as ``toggle``, and a
#: toggle is written as 1.
FAMILY_ACTIONS = ("none", "toggle", "toggle")
#: Per node, a JSON list: a goal's own ``attributes`` (a slot's row, a bin's colour), ``{}``
#: for an object or a fixture (``observation.nodes.attributes`` holds a goal's ``accepts``).
#: Absent from datasets written before it: goals read with no attributes.
GOAL_ATTRIBUTES = f"{NODES}.goal_attributes"
