"""The dishwasher's loading preference (docs/dishwasher.md), written once for its sim, planner
and skills parts: which rack, and which side of it, a preference puts each kind of dish in.
The sim judges success by it (``sim.model.allowed``), the expert demonstrates it
(``planner.expert``). A common module of the package: it imports no service.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Final

from manigraph_dishwasher.rules import BOTTOM_RACK, TOP_RACK
from manigraph_shared.errors import TaskError

PLATE: Final = "plate"
BOWL: Final = "bowl"
DISH_KINDS: Final = (PLATE, BOWL)


class Preference(StrEnum):
    """How the user wants the dishwasher loaded (what the five demonstrations show)."""

    #: Bowls in the top rack, plates in the bottom rack.
    TOP_BOTTOM = "top-bottom"
    #: Everything in the top rack: bowls on the right (y > 0), plates on the left.
    LEFT_RIGHT = "left-right"

    @classmethod
    def parse(cls, value: str | None) -> Preference:
        """``value`` as a preference (None: top-bottom); ``TaskError`` naming the known ones."""
        if value is None:
            return cls.TOP_BOTTOM
        try:
            return cls(value)
        except ValueError:
            known = ", ".join(p.value for p in cls)
            raise TaskError(f"preference: '{value}' is not one of {known}") from None


def preferred_rack(preference: Preference, dish_kind: str) -> str:
    """The rack ``preference`` loads a ``dish_kind`` into: top-bottom, bowls in the top rack
    and plates in the bottom one; left-right, everything in the top rack."""
    if preference is Preference.TOP_BOTTOM:
        return TOP_RACK if dish_kind == BOWL else BOTTOM_RACK
    return TOP_RACK


def allows(
    preference: Preference, dish_kind: str, slot_kind: str, slot_rack: str | None, left: bool
) -> bool:
    """Whether ``preference`` lets a ``dish_kind`` stand in a slot that takes ``slot_kind``,
    in rack ``slot_rack``, on the left (``left``: y < 0, as the caller's world measures it):
    a slot of the dish's kind, in its preferred rack, and for left-right on its side (plates
    on the left, bowls on the right)."""
    if slot_kind != dish_kind or slot_rack != preferred_rack(preference, dish_kind):
        return False
    return preference is Preference.TOP_BOTTOM or left == (dish_kind == PLATE)


#: The registered name of the expert of each preference (its planner part registers them).
EXPERTS: Final = {
    Preference.TOP_BOTTOM: "dishwasher-top-bottom",
    Preference.LEFT_RIGHT: "dishwasher-left-right",
}


def expert_name(preference: str | None) -> str:
    """The expert of ``preference`` (unset: top-bottom, as the sim lays it out; an unknown
    one is the sim's to refuse when the episode starts: top-bottom here)."""
    known = {p.value: p for p in Preference}
    return EXPERTS[known.get(preference or "", Preference.TOP_BOTTOM)]
