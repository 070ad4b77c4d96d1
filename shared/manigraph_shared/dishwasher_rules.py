"""The dishwasher task's loading rules (docs/dishwasher.md), declared once: the geometric
world refuses an action with them, and the skills check them on the ``Scene`` for a robot
whose world does not refuse anything by itself (the physics world, a real dishwasher).

Each check raises a ``SkillError`` whose reason names the rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final

from manigraph_shared.errors import SkillError

TOP_RACK: Final = "rack_top"
BOTTOM_RACK: Final = "rack_bottom"


def check_rack_usable(rack_id: str, open_racks: Mapping[str, bool]) -> None:
    """A rack is loaded (or unloaded) only when pulled out (``rack_closed``); the bottom one
    only while the top one is pushed in (``top_rack_open``): the open top rack is in the way.
    ``open_racks``: every rack's open flag."""
    if not open_racks.get(rack_id, False):
        raise SkillError("rack_closed", f"{rack_id} is pushed in")
    if rack_id == BOTTOM_RACK and open_racks.get(TOP_RACK, False):
        raise SkillError("top_rack_open", "the bottom rack is loaded only with the top one in")


def check_slot(
    slot_id: str, slot_kind: str, dish_id: str, dish_kind: str, occupant: str | None
) -> None:
    """A slot holds one dish (``slot_taken``) of its own kind (``wrong_slot``); ``occupant``
    is the dish in it now, if any."""
    if occupant is not None and occupant != dish_id:
        raise SkillError("slot_taken", f"{slot_id} holds {occupant}")
    if slot_kind != dish_kind:
        raise SkillError("wrong_slot", f"{slot_id} takes a {slot_kind}, not a {dish_kind}")
