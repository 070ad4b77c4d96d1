"""Contract version 4 took the dishwasher out of the contract: a v3 log's racks, tray actions,
toggle op and preference still decode, into fixtures, family actions, ``operate`` and options
(``manigraph_shared.messages.legacy``). The v3 payloads are written here by hand, as v3 wrote
them."""

from __future__ import annotations

import json

import pytest

from manigraph_shared.errors import MessageError
from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    GripperOp,
    RobotCommand,
    Scene,
    SceneFixture,
    Vector3,
)

_AT = {"x": 0.5, "y": 0.1, "z": 0.3}
V3_SCENE = {
    "episode_id": "dish-1",
    "stamp": 10.0,
    "sequence": 3,
    "objects": [
        {"id": "plate_0", "category": "plate", "position": _AT, "size": _AT, "filled": False}
    ],
    "goals": [
        {"id": "slot_0", "category": "plate", "position": _AT, "rack": "rack_bottom"},
        {"id": "slot_1", "category": "bowl", "position": _AT, "rack": None},
    ],
    "racks": [
        {"id": "rack_top", "position": _AT, "open": False},
        {"id": "rack_bottom", "position": _AT, "open": True, "travel": 0.3, "rail": 0.35},
    ],
}
V3_TOGGLE = {
    "decision_id": "dish-1:4",
    "episode_id": "dish-1",
    "scene_sequence": 3,
    "object_id": "rack_top",
    "goal_id": "rack_top",
    "tray_action": "toggle_top",
    "policy": "dishwasher-top-bottom",
    "stamp": 10.5,
}


def _wire(data: dict[str, object]) -> bytes:
    return json.dumps(data).encode()


def test_a_v3_scene_decodes_its_racks_as_rack_fixtures() -> None:
    scene = Scene.decode(_wire(V3_SCENE))
    assert [(f.id, f.kind, f.state) for f in scene.fixtures] == [
        ("rack_top", "rack", {"open": False}),
        ("rack_bottom", "rack", {"open": True, "travel": 0.3, "rail": 0.35}),
    ]
    assert [g.fixture for g in scene.goals] == ["rack_bottom", None]
    assert scene.fixture("rack_bottom").position == Vector3(x=0.5, y=0.1, z=0.3)
    again = Scene.decode(scene.encode())  # and it is a v4 scene now
    assert again == scene and "racks" not in json.loads(scene.encode())


def test_v3_actions_decode_their_tray_action_as_the_family_action() -> None:
    toggle = Action.decode(_wire(V3_TOGGLE))
    assert (toggle.family_action, toggle.object_id, toggle.goal_id) == (
        "toggle",
        "rack_top",
        "rack_top",
    )
    placement = {**V3_TOGGLE, "object_id": "plate_0", "goal_id": "slot_0", "tray_action": "none"}
    assert Action.decode(_wire(placement)).family_action is None
    no_field = {k: v for k, v in placement.items() if k != "tray_action"}
    assert Action.decode(_wire(no_field)).family_action is None  # v1-v2: no such field


def test_a_v3_toggle_tray_command_decodes_as_operate() -> None:
    command = {
        "command_id": "c",
        "decision_id": "dish-1:4",
        "op": "toggle_tray",
        "object_id": "rack_top",
        "position": _AT,
        "stamp": 1.0,
    }
    assert RobotCommand.decode(_wire(command)).op is GripperOp.OPERATE


def test_a_v3_request_decodes_its_preference_as_a_family_option() -> None:
    request = {"episode_id": "e", "task": "dishwasher", "objects": 6, "preference": "left-right"}
    decoded = EpisodeRequest.decode(_wire(request))
    assert (decoded.family, decoded.objects, decoded.options) == (
        None,
        6,
        {"preference": "left-right"},
    )
    unset = EpisodeRequest.decode(_wire({**request, "preference": None}))
    assert unset.options == {}


def test_what_is_wrong_in_a_v3_payload_is_still_refused_naming_the_field() -> None:
    bad = {**V3_SCENE, "racks": [{"id": "rack_top", "position": _AT, "open": [True]}]}
    with pytest.raises(MessageError, match="fixtures"):
        Scene.decode(_wire(bad))
    with pytest.raises(MessageError, match="sequence"):
        Scene.decode(_wire({**V3_SCENE, "sequence": -1}))


def test_a_family_action_names_its_fixture_as_object_and_goal() -> None:
    with pytest.raises(ValueError, match="goal_id"):
        Action.decode(_wire({**V3_TOGGLE, "goal_id": "slot_0"}))


def test_a_fixture_state_is_bounded_scalars() -> None:
    at = Vector3(x=0.0, y=0.0, z=0.0)
    SceneFixture(id="drawer", kind="drawer", position=at, state={"open": True, "travel": 0.1})
    encoded = json.dumps(
        {"id": "d", "kind": "drawer", "position": _AT, "state": {"open": [1, 2]}}
    ).encode()
    scene = {**V3_SCENE, "racks": []}
    with pytest.raises(MessageError):
        Scene.decode(_wire({**scene, "fixtures": [json.loads(encoded)]}))
    with pytest.raises(MessageError):
        Scene.decode(_wire({**scene, "fixtures": [{**json.loads(encoded), "kind": "Rack!"}]}))
