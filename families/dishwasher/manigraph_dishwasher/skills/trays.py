"""ToggleTray: the dishwasher's tray action, run by the driver's ``toggle_tray``."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from manigraph_dishwasher.rack_geometry import RACK_TRAVEL, rack_grip
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Action, Scene, SceneRack, SkillState, SkillStatus
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
    rack_id = action.tray_action.rack_id
    assert rack_id is not None
    try:
        rack = scene.rack(rack_id)
    except KeyError:
        raise SkillError("unknown_rack", f"the scene has no {rack_id}") from None
    if not runner.workspace.contains(rack.position):
        raise SkillError("outside_workspace", f"{rack_id} handle at {rack.position.as_tuple()}")
    status(SkillState.RUNNING)
    runner.driver.toggle_tray(tray_toggle(action.decision_id, rack))


def tray_toggle(decision_id: str, rack: SceneRack) -> TrayToggle:
    """The driver's toggle of ``rack`` as the scene shows it: its tab where
    ``rack_geometry.rack_grip`` says, its rail the scene's, else ``RACK_TRAVEL``
    (``ConfigError`` naming a rack without a handle)."""
    rail = RACK_TRAVEL if rack.rail is None else rack.rail
    x, y, z = (float(v) for v in rack_grip(rack.id))
    return TrayToggle(
        decision_id, rack.id, rack.position, rack.open, rail, (x, y, z), travel=rack.travel
    )
