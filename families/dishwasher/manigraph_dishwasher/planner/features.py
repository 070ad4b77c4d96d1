r"""The dishwasher's graph state: dishes, slots and racks as nodes of one complete graph.

The paper's node feature (category, position, filled) extended with what the dishwasher needs
(section 'Dishwasher loading'): dish types, racks as nodes with an open flag, orientations.
Nodes are ordered dishes, then slots, then racks. Each node has the 17-dimensional feature

.. math::
    \phi(v) = [\,\mathrm{onehot}(c),\; x,\; y,\; z,\; f,\; o,\; \mathrm{onehot}(r)\,]

* :math:`c` — plate, bowl, plate slot, bowl slot, top rack, bottom rack (6 columns);
* :math:`x, y, z` — position in the scene frame, metres (a rack: its handle);
* :math:`f` — a dish stands in a slot, or a slot holds a dish;
* :math:`o` — a rack is pulled out (0 for dishes and slots);
* :math:`r` — a dish's orientation now, or the one a slot requires (6 columns,
  ``manigraph_shared.orientations``; zeros for racks).

Its :class:`~manigraph_planner.gnn.features.FeatureSpec` is stamped into checkpoints with
``dishwasher`` heads, so a checkpoint built for another layout is refused naming the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import Tensor

from manigraph_dishwasher.fixtures import TRAY_RACKS, TrayAction, racks
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Scene
from manigraph_shared.orientations import (
    NUM_ORIENTATIONS,
    nearest_orientation,
    up_axis_orientation,
)

__all__ = [
    "DISH_FEATURE_SPEC",
    "FILLED_COLUMN",
    "ORIENTATION_COLUMNS",
    "POSITION_COLUMNS",
    "TRAY_ACTIONS",
    "DishGraph",
    "dish_scene_to_graph",
]

_CATEGORIES = ("plate", "bowl", "plate-slot", "bowl-slot", "rack-top", "rack-bottom")
DISH_FEATURE_SPEC = FeatureSpec(
    names=(
        *(f"is-{c}" for c in _CATEGORIES),
        "x",
        "y",
        "z",
        "filled",
        "open",
        *(f"orientation-{i}" for i in range(NUM_ORIENTATIONS)),
    ),
    category_codes=tuple((c, i) for i, c in enumerate(_CATEGORIES)),
    version="dishwasher-1",
)
#: The tray head's classes, in order (the paper: toggle top, toggle bottom, no-op).
TRAY_ACTIONS = (TrayAction.TOGGLE_TOP, TrayAction.TOGGLE_BOTTOM, TrayAction.NONE)
_RACK_CODE = {TRAY_RACKS[TrayAction.TOGGLE_TOP]: 4, TRAY_RACKS[TrayAction.TOGGLE_BOTTOM]: 5}
_DISH_CODE = {"plate": 0, "bowl": 1}
_SLOT_CODE = {"plate": 2, "bowl": 3}
_POSITION = len(_CATEGORIES)
_ORIENTATION = _POSITION + 5
#: Where the "filled" flag is.
FILLED_COLUMN = _POSITION + 3
#: Where a node's position (x, y, z) is.
POSITION_COLUMNS = slice(_POSITION, _POSITION + 3)
#: Where a node's orientation (one-hot: a dish's now, the one a slot requires) is.
ORIENTATION_COLUMNS = slice(_ORIENTATION, _ORIENTATION + NUM_ORIENTATIONS)


@dataclass
class DishGraph:
    """One dishwasher scene as a graph: ``x[:K]`` dishes, ``x[K:K+L]`` slots, then racks.

    Shapes:
        - **x:** :math:`(N, 17)` float32
    """

    x: Tensor
    object_ids: list[str]
    goal_ids: list[str]
    rack_ids: list[str]
    #: The rack of each slot (``SceneGoal.fixture``), and whether each rack is out.
    goal_racks: list[str | None] = field(default_factory=list)
    rack_open: dict[str, bool] = field(default_factory=dict)

    @property
    def num_objects(self) -> int:
        return len(self.object_ids)

    @property
    def num_goals(self) -> int:
        return len(self.goal_ids)

    def goal_codes(self) -> Tensor:
        return self.x[:, :_POSITION].argmax(dim=1)


def dish_scene_to_graph(scene: Scene) -> DishGraph:
    """The graph state of a dishwasher ``scene`` (visible dishes and slots, every rack).

    Raises:
        PolicyError: the scene holds something that is not part of the dishwasher task.
    """
    rows: list[Tensor] = []
    object_ids, goal_ids, rack_ids = [], [], []
    goal_racks: list[str | None] = []

    def row(code: int, p: tuple[float, float, float], filled: float, open_: float, o: int | None):
        r = torch.zeros(DISH_FEATURE_SPEC.num_features)
        r[code] = 1.0
        r[_POSITION : _POSITION + 3] = torch.tensor(p)
        r[_POSITION + 3] = filled
        r[_POSITION + 4] = open_
        if o is not None:
            r[_ORIENTATION + o] = 1.0
        rows.append(r)

    for obj in scene.objects:
        if obj.category.value not in _DISH_CODE:
            raise PolicyError(f"scene: object '{obj.id}' is a {obj.category}, not a dish")
        if obj.visible:
            o = up_axis_orientation(obj.orientation)  # at any yaw (a physical dish)
            row(_DISH_CODE[obj.category.value], obj.position.as_tuple(), obj.filled, 0.0, o)
            object_ids.append(obj.id)
    for goal in scene.goals:
        if goal.category.value not in _SLOT_CODE:
            raise PolicyError(f"scene: goal '{goal.id}' is a {goal.category}, not a rack slot")
        if goal.visible:
            o = nearest_orientation(goal.orientation)
            row(_SLOT_CODE[goal.category.value], goal.position.as_tuple(), goal.filled, 0.0, o)
            goal_ids.append(goal.id)
            goal_racks.append(goal.fixture)
    scene_racks = racks(scene)
    for rack in scene_racks:
        if rack.id not in _RACK_CODE:
            raise PolicyError(f"scene: rack '{rack.id}' is not one of {sorted(_RACK_CODE)}")
        row(_RACK_CODE[rack.id], rack.position.as_tuple(), 0.0, float(rack.open), None)
        rack_ids.append(rack.id)
    x = torch.stack(rows) if rows else torch.zeros(0, DISH_FEATURE_SPEC.num_features)
    rack_open = {rack.id: rack.open for rack in scene_racks}
    return DishGraph(x, object_ids, goal_ids, rack_ids, goal_racks, rack_open)
