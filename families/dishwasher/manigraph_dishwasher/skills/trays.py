"""ToggleTray: the dishwasher's tray action (the family action ``toggle``), run by the
driver's ``toggle_tray`` (an ``operate`` command)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from manigraph_dishwasher.fixtures import Rack, TrayAction, rack
from manigraph_dishwasher.rack_geometry import RACK_TRAVEL, rack_grip
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Action, Scene, SkillState, SkillStatus
from manigraph_skills.drivers.base import TrayToggle

if TYPE_CHECKING:
    from manigraph_skills.pick_and_place import PickAndPlace


def toggle_tray(
    runner: PickAndPlace,
    action: Action,
    scene: Scene,
    status: Callable[[SkillState], SkillStatus],
) -> None:
    """The rack the tray action names, if the scene has it, pushed in or pulled out."""
    rack_id = TrayAction.of(action).rack_id or action.object_id
    try:
        toggled = rack(scene, rack_id)
    except KeyError:
        raise SkillError("unknown_rack", f"the scene has no {rack_id}") from None
    if not runner.workspace.contains(toggled.position):
        raise SkillError("outside_workspace", f"{rack_id} handle at {toggled.position.as_tuple()}")
    status(SkillState.RUNNING)
    runner.driver.toggle_tray(tray_toggle(action.decision_id, toggled))


def tray_toggle(decision_id: str, rack: Rack) -> TrayToggle:
    """The driver's toggle of ``rack`` as the scene shows it: its tab where
    ``rack_geometry.rack_grip`` says, its rail the scene's, else ``RACK_TRAVEL``
    (``ConfigError`` naming a rack without a handle)."""
    rail = RACK_TRAVEL if rack.rail is None else rack.rail
    x, y, z = (float(v) for v in rack_grip(rack.id))
    return TrayToggle(
        decision_id, rack.id, rack.position, rack.open, rail, (x, y, z), travel=rack.travel
    )
