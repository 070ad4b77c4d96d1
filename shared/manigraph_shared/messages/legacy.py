"""Payloads of contract versions 1-3 in version 4's fields, so older logs still replay.

Version 4 took the one task family the contract knew out of it (``base.CONTRACT_VERSION``).
What versions 1-3 carried for it maps onto the generic fields one to one:

* a scene's ``racks`` are its ``fixtures`` of kind ``rack`` (``open``, ``travel`` and
  ``rail`` in their ``state``), and a goal's ``rack`` is its ``fixture``;
* an action's ``tray_action`` (``toggle_top``, ``toggle_bottom``; its rack was already named
  as object and goal) is the ``family_action`` ``toggle``; ``none`` is no family action;
* the robot's ``toggle_tray`` op is ``operate``;
* an episode request's ``preference`` is its ``options["preference"]``.

Each function takes a payload as JSON builtins and returns it in version 4's fields (the
payload itself when it holds nothing older). A message type's ``upgrade`` calls its function
only for a payload that did not decode as is.
"""

from __future__ import annotations

from typing import Any

#: The fixture kind and the family action versions 1-3 carried as racks and tray actions.
RACK_KIND = "rack"
TOGGLE = "toggle"
#: A rack's fields that became its fixture's state.
_RACK_STATE = ("open", "travel", "rail")


def scene(data: dict[str, Any]) -> dict[str, Any]:
    """A scene's ``racks`` as fixtures and its goals' ``rack`` as their ``fixture``."""
    given = data.get("goals")
    goals: list[Any] = given if isinstance(given, list) else []
    old_goals = any(isinstance(g, dict) and "rack" in g for g in goals)
    if "racks" not in data and not old_goals:
        return data
    upgraded = dict(data)
    racks = upgraded.pop("racks", None) or []
    fixtures = [_rack_fixture(rack) if isinstance(rack, dict) else rack for rack in racks]
    if fixtures:
        upgraded["fixtures"] = [*(upgraded.get("fixtures") or []), *fixtures]
    if old_goals:
        upgraded["goals"] = [_goal(goal) for goal in goals]
    return upgraded


def _rack_fixture(rack: dict[str, Any]) -> dict[str, Any]:
    fixture = {k: v for k, v in rack.items() if k not in _RACK_STATE}
    fixture["kind"] = RACK_KIND
    fixture["state"] = {k: rack[k] for k in _RACK_STATE if rack.get(k) is not None}
    return fixture


def _goal(goal: object) -> object:
    if not isinstance(goal, dict) or "rack" not in goal:
        return goal
    upgraded = {k: v for k, v in goal.items() if k != "rack"}
    if goal["rack"] is not None:
        upgraded["fixture"] = goal["rack"]
    return upgraded


def action(data: dict[str, Any]) -> dict[str, Any]:
    """An action's ``tray_action`` as its ``family_action``."""
    if "tray_action" not in data:
        return data
    upgraded = {k: v for k, v in data.items() if k != "tray_action"}
    if data["tray_action"] not in (None, "none"):
        upgraded["family_action"] = TOGGLE
    return upgraded


def robot_command(data: dict[str, Any]) -> dict[str, Any]:
    """The robot's ``toggle_tray`` op as ``operate``."""
    if data.get("op") != "toggle_tray":
        return data
    return {**data, "op": "operate"}


def episode_request(data: dict[str, Any]) -> dict[str, Any]:
    """An episode request's ``preference`` as one of its ``options``."""
    if "preference" not in data:
        return data
    upgraded = {k: v for k, v in data.items() if k != "preference"}
    if data["preference"] is not None:
        upgraded["options"] = {**(data.get("options") or {}), "preference": data["preference"]}
    return upgraded
