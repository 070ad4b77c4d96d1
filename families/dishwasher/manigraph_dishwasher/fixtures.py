"""The dishwasher's racks and tray actions as the contract carries them.

The contract knows no family (``manigraph_shared.messages.base``, version 4): a rack is a
scene fixture of kind ``rack`` whose ``state`` holds ``open`` (pulled out: it can be loaded),
``travel`` (how far it is out, metres, where measured) and ``rail`` (how far it slides out
all the way, where the world says so); a slot names its rack as its ``fixture``. A tray
action is the family action ``toggle`` naming its rack as object and goal. This module is
the one place that reads and writes them so; the rest of the family works with :class:`Rack`
and :class:`TrayAction`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol

from manigraph_shared.messages import Action, Scene, SceneFixture, Vector3

#: The fixture kind of a rack and the family action that toggles one.
RACK = "rack"
TOGGLE = "toggle"


@dataclass(frozen=True)
class Rack:
    """A rack that slides out (open) and in along its rail, as a scene shows it."""

    id: str
    #: Centre of the rack's handle, metres.
    position: Vector3
    open: bool
    travel: float | None = None
    rail: float | None = None

    def fixture(self) -> SceneFixture:
        """This rack as the scene's fixture."""
        state: dict[str, bool | float | str] = {"open": self.open}
        if self.travel is not None:
            state["travel"] = self.travel
        if self.rail is not None:
            state["rail"] = self.rail
        return SceneFixture(id=self.id, kind=RACK, position=self.position, state=state)


def rack_of(fixture: SceneFixture) -> Rack:
    """``fixture`` (of kind ``rack``) as a :class:`Rack`."""
    state = fixture.state
    travel, rail = state.get("travel"), state.get("rail")
    return Rack(
        id=fixture.id,
        position=fixture.position,
        open=bool(state.get("open", False)),
        travel=None if travel is None else float(travel),
        rail=None if rail is None else float(rail),
    )


def racks(scene: Scene) -> list[Rack]:
    """The scene's racks, in its order."""
    return [rack_of(f) for f in scene.fixtures if f.kind == RACK]


def rack(scene: Scene, rack_id: str) -> Rack:
    """The scene's rack ``rack_id`` (``KeyError`` if it has none)."""
    fixture = scene.fixture(rack_id)
    if fixture.kind != RACK:
        raise KeyError(rack_id)
    return rack_of(fixture)


class Decided(Protocol):
    """A decision as a policy makes it (``manigraph_planner``'s ``Decision``)."""

    object_id: str
    family_action: str | None


class TrayAction(StrEnum):
    """The dishwasher's extra action head (paper, section 'Dishwasher loading'): which rack
    to toggle, if any."""

    NONE = "none"
    TOGGLE_TOP = "toggle_top"
    TOGGLE_BOTTOM = "toggle_bottom"

    @property
    def rack_id(self) -> str | None:
        """The id of the rack this action toggles, None for NONE."""
        return TRAY_RACKS.get(self)

    @classmethod
    def of(cls, action: Action | Decided) -> TrayAction:
        """The tray action ``action`` (the contract's, or a policy's decision) is (NONE for
        a pick and place, or another family action)."""
        if action.family_action != TOGGLE:
            return cls.NONE
        return _BY_RACK.get(action.object_id, cls.NONE)

    @property
    def family_action(self) -> str | None:
        """The contract's ``Action.family_action`` for this tray action."""
        return None if self is TrayAction.NONE else TOGGLE


#: The dishwasher's racks by the tray action that toggles them.
TRAY_RACKS: dict[TrayAction, str] = {
    TrayAction.TOGGLE_TOP: "rack_top",
    TrayAction.TOGGLE_BOTTOM: "rack_bottom",
}
_BY_RACK = {rack_id: tray for tray, rack_id in TRAY_RACKS.items()}
