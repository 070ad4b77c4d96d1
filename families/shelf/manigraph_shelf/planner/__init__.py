"""The shelf family's planner: its expert (:mod:`.expert`, ``shelf-expert``: every back slot
before any front slot). Its policies have the paper's ``object-goal`` heads, built, loaded
and trained by the generic layers, so it names none of those parts; a slot's row
(``shelf_row``, a goal attribute) reaches a learned policy as a task feature column."""

from manigraph_planner.family import PlannerFamily
from manigraph_shelf.planner import expert  # noqa: F401  (registers its expert)
from manigraph_shelf.shelf_geometry import is_shelf_scene

#: This family's planner part (its package's ``manigraph.families`` entry names it).
FAMILY = PlannerFamily(
    name="shelf",
    heads="object-goal",
    experts=("shelf-expert",),
    matches=is_shelf_scene,
    help="blocks onto a shelf's boards: object and goal heads",
)
