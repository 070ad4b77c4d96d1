"""The shelf family's skill extensions: a block is put into a slot by its own action
(:mod:`.place_from_front`: a side grasp off the table and a horizontal-approach place from
the front, under the board above, :mod:`.front_motion`), and the cupboard's boards and walls
are obstacles (:mod:`.obstacles`)."""

import re

from manigraph_shared.messages import Action
from manigraph_shelf.shelf_geometry import is_shelf_scene
from manigraph_skills.family import SkillFamily

#: A shelf slot's goal id (``shelf_geometry.Slot``: ``slot_<level>_<column>_<row>``).
SLOT_ID = re.compile(r"slot_\d+_\d+_(back|front)")


def _is_slot_action(action: Action) -> bool:
    """A move into a shelf slot (its goal names one): this family's own place."""
    return SLOT_ID.fullmatch(action.goal_id) is not None


_HERE = "manigraph_shelf.skills"
#: This family's skills part (its package's ``manigraph.families`` entry names it).
FAMILY = SkillFamily(
    name="shelf",
    matches=is_shelf_scene,
    takes=_is_slot_action,
    run_action=f"{_HERE}.place_from_front:place_from_front",
    obstacles=f"{_HERE}.obstacles:cupboard_obstacles",
    help="a place into a slot from the front, under the board above; the cupboard as obstacles",
)
