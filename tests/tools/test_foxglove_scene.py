"""Scene, decision and explanation as Foxglove SceneUpdate / FrameTransforms (no network)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from foxglove.messages import FrameTransforms, SceneUpdate

from manigraph_shared.colours import PALETTE
from manigraph_shared.messages import (
    Action,
    ExplainedEdge,
    ExplainedNode,
    Explanation,
    GoalCategory,
    JointState,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS, HOME_Q
from manigraph_tools.foxglove_bridge import SCENE_TOPIC, TF_TOPIC, FoxgloveBridge
from manigraph_tools.foxglove_layout import layout_json
from manigraph_tools.foxglove_scene import scene_update
from manigraph_tools.panda_frames import TCP_FRAME, rotate, world_poses

ProtobufDecoder = Callable[[str, bytes, bytes], dict[str, Any]]


def v(x: float, y: float, z: float) -> Vector3:
    return Vector3(x=x, y=y, z=z)


def box_scene(sequence: int = 7) -> Scene:
    return Scene(
        episode_id="ep-1",
        stamp=1_700_000_000.25,
        sequence=sequence,
        objects=[
            SceneObject(id="block_0", category=ObjectCategory.BLOCK, position=v(0.4, 0.1, 0.02),
                        size=v(0.04, 0.04, 0.04)),
            SceneObject(id="cover_0", category=ObjectCategory.COVER, position=v(0.5, -0.2, 0.065),
                        size=v(0.16, 0.16, 0.01)),
        ],
        goals=[
            SceneGoal(id="goal_0", category=GoalCategory.BLOCK, position=v(0.3, -0.1, 0.02)),
            SceneGoal(id="lid_0", category=GoalCategory.COVER, position=v(0.5, -0.2, 0.065),
                      filled=True),
            SceneGoal(id="store_0", category=GoalCategory.COVER, position=v(0.3, 0.3, 0.005)),
        ],
    )  # fmt: skip


def action(decision: str = "ep-1:0") -> Action:
    return Action(
        decision_id=decision,
        episode_id="ep-1",
        scene_sequence=7,
        object_id="block_0",
        goal_id="goal_0",
        policy="expert",
        stamp=1_700_000_000.5,
    )


def explanation(decision: str = "ep-1:0") -> Explanation:
    return Explanation(
        decision_id=decision,
        episode_id="ep-1",
        scene_sequence=7,
        policy="sage",
        object="block_0",
        goal="goal_0",
        edges=[
            ExplainedEdge(src="block_0", dst="goal_0", weight=0.9),
            ExplainedEdge(src="cover_0", dst="goal_0", weight=0.2),
            ExplainedEdge(src="cover_0", dst="block_0", weight=0.01),
        ],
        features={"x": 1.0},
        nodes=[
            ExplainedNode(id="block_0", category="block", position=v(0.4, 0.1, 0.02)),
            ExplainedNode(id="goal_0", category="block-goal", position=v(0.3, -0.1, 0.02)),
            ExplainedNode(id="cover_0", category="cover", position=v(0.5, -0.2, 0.065)),
        ],
        sentence="because",
        fidelity=0.8,
        seed=0,
        stamp=1_700_000_000.6,
    )


def decoded_update(decode: ProtobufDecoder, update: Any) -> dict[str, dict[str, Any]]:
    schema = SceneUpdate.get_schema()
    message = decode("foxglove.SceneUpdate", schema.data, update.encode())
    assert message["deletions"][0]["type"] == "ALL"
    return {entity["id"]: entity for entity in message["entities"]}


def xyz(pose: dict[str, Any]) -> tuple[float, float, float]:
    p = pose["position"]
    return (p["x"], p["y"], p["z"])


def test_objects_and_goals_are_cubes_where_the_scene_has_them(
    decode_protobuf: ProtobufDecoder,
) -> None:
    scene = box_scene()
    entities = decoded_update(decode_protobuf, scene_update(scene))
    for item in [*scene.objects, *scene.goals]:
        kind = "object" if item in scene.objects else "goal"
        entity = entities[f"{kind}/{item.id}"]
        assert entity["frame_id"] == "world"
        assert entity["metadata"] == [{"key": "scene_sequence", "value": "7"}]
        assert xyz(entity["cubes"][0]["pose"]) == pytest.approx(item.position.as_tuple())
    block = entities["object/block_0"]["cubes"][0]
    assert (block["size"]["x"], block["color"]["a"]) == (0.04, 1.0)
    free, filled = entities["goal/goal_0"]["cubes"][0], entities["goal/lid_0"]["cubes"][0]
    assert free["color"]["a"] < 1.0 and filled["color"]["a"] < 1.0  # translucent
    assert free["color"]["g"] != filled["color"]["g"]  # coloured by filled
    # A cover goal sized like the cover, a block goal like the block.
    assert filled["size"]["x"] == 0.16 and free["size"]["x"] == 0.04
    # A box under the lid's place, none under the storage place on the table.
    assert len(entities["box/lid_0"]["cubes"]) == 4
    assert "box/store_0" not in entities
    assert "decision" not in entities and "explanation" not in entities


def test_the_decision_is_an_arrow_from_the_object_to_the_goal(
    decode_protobuf: ProtobufDecoder,
) -> None:
    scene = box_scene()
    arrow = decoded_update(decode_protobuf, scene_update(scene, action()))["decision"]["arrows"][0]
    start, end = scene.object("block_0").position, scene.goal("goal_0").position
    assert xyz(arrow["pose"]) == pytest.approx(start.as_tuple())
    q = arrow["pose"]["orientation"]
    direction = rotate((q["x"], q["y"], q["z"], q["w"]), (1.0, 0.0, 0.0))
    delta = [e - s for s, e in zip(start.as_tuple(), end.as_tuple(), strict=True)]
    length = math.dist(start.as_tuple(), end.as_tuple())
    assert direction == pytest.approx([d / length for d in delta])
    assert arrow["shaft_length"] + arrow["head_length"] == pytest.approx(length)


def test_a_decision_of_another_episode_is_not_drawn(decode_protobuf: ProtobufDecoder) -> None:
    other = action().replace(episode_id="ep-2")
    assert "decision" not in decoded_update(decode_protobuf, scene_update(box_scene(), other))


def test_explanation_edges_are_lines_weighted_by_importance(
    decode_protobuf: ProtobufDecoder,
) -> None:
    update = scene_update(box_scene(), action(), explanation())
    lines = decoded_update(decode_protobuf, update)["explanation"]["lines"]
    assert len(lines) == 2  # the 0.01 edge is left out
    strong, weak = lines
    assert strong["thickness"] > weak["thickness"]
    assert strong["color"]["a"] > weak["color"]["a"]
    assert [xyz({"position": p}) for p in strong["points"]] == [(0.4, 0.1, 0.02), (0.3, -0.1, 0.02)]


def test_the_bridge_keeps_the_latest_decision_and_drops_stale_explanations(
    decode_protobuf: ProtobufDecoder,
) -> None:
    bridge = FoxgloveBridge()
    assert bridge.on_message(action()) == []  # nothing to draw before a scene
    first = bridge.on_message(box_scene())
    assert [c.topic for c in first] == [SCENE_TOPIC, TF_TOPIC]  # base frame once
    assert [c.topic for c in bridge.on_message(box_scene(8))] == [SCENE_TOPIC]
    bridge.on_message(explanation())
    assert "explanation" in decoded_update(decode_protobuf, bridge.update())
    (converted,) = bridge.on_message(action("ep-1:1"))
    entities = decoded_update(decode_protobuf, converted.message)
    assert "decision" in entities and "explanation" not in entities
    assert bridge.convert(Scene.key, b'{"not": "a scene"}') == []
    assert bridge.rejected == 1


def test_forward_kinematics_puts_the_tcp_where_the_ready_pose_says(
    decode_protobuf: ProtobufDecoder,
) -> None:
    state = JointState(
        joint_names=list(ARM_JOINTS), positions=HOME_Q.tolist(), gripper_width=0.08, stamp=5.0
    )
    position, rotation = world_poses(state)[TCP_FRAME]
    # manigraph_shared.panda: TCP at (0.31, 0, 0.49) m, fingers pointing down, closing along x.
    assert position == pytest.approx((0.31, 0.0, 0.49), abs=0.005)
    assert rotate(rotation, (0.0, 0.0, 1.0)) == pytest.approx((0.0, 0.0, -1.0), abs=1e-9)
    assert rotate(rotation, (0.0, 1.0, 0.0)) == pytest.approx((1.0, 0.0, 0.0), abs=1e-9)
    (converted,) = FoxgloveBridge().on_message(state)
    assert converted.topic == TF_TOPIC
    schema = FrameTransforms.get_schema()
    message = decode_protobuf(schema.name, schema.data, converted.message.encode())
    links = {t["child_frame_id"]: t for t in message["transforms"]}
    assert links["panda_link0"]["parent_frame_id"] == "world"
    assert {f"panda_link{i}" for i in range(8)} | {"panda_hand", TCP_FRAME} <= set(links)
    assert links["panda_link1"]["translation"]["z"] == pytest.approx(0.333)


def test_the_documented_layout_is_the_one_the_tools_build() -> None:
    """docs/foxglove-layout.json is regenerated by `manigraph view --print-layout`."""
    documented = Path(__file__).resolve().parents[2] / "docs" / "foxglove-layout.json"
    assert documented.read_text() == layout_json(), (
        "regenerate: manigraph view --print-layout > docs/foxglove-layout.json"
    )
    panel = json.loads(documented.read_text())["content"]["items"][0]["content"]
    assert panel["panelType"] == "ThreeDee"
    assert panel["config"]["topics"] == {SCENE_TOPIC: {"visible": True}}


def test_the_layout_has_the_camera_joint_plots_and_decision_tables() -> None:
    """Every panel docs/foxglove.md promises, on the topics a run writes."""
    from manigraph_shared.messages import Action, Explanation, JointState

    def panels(node: dict[str, Any]) -> list[dict[str, Any]]:
        if node.get("type") == "panel":
            return [node]
        return [p for item in node.get("items", []) for p in panels(item["content"])]

    found = panels(json.loads(layout_json())["content"])
    by_type: dict[str, list[dict[str, Any]]] = {}
    for panel in found:
        by_type.setdefault(panel["panelType"], []).append(panel["config"])
    [image] = by_type["Image"]
    assert image["imageMode"]["imageTopic"] == "/camera/front/image"
    assert image["imageMode"]["calibrationTopic"] == "/camera/front/calibration"
    assert image["imageMode"]["annotations"] == {"/camera/front/markers": {"visible": True}}
    [plot] = by_type["Plot"]
    assert [series["value"] for series in plot["paths"]] == [
        f"{JointState.key}.positions[{i}]" for i in range(len(ARM_JOINTS))
    ]
    assert [series["label"] for series in plot["paths"]] == list(ARM_JOINTS)
    assert sorted(table["topicPath"] for table in by_type["Table"]) == sorted(
        [Action.key, Explanation.key]
    )


def test_dish_slots_are_drawn_sized_like_their_dishes(decode_protobuf: ProtobufDecoder) -> None:
    # A recorder once lost every later sample of a dishwasher run: its view had no size for
    # a plate slot and the writer thread died on the KeyError.
    from manigraph_shared.messages import EpisodeRequest
    from manigraph_sim.geometric.backend import GeometricBackend

    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=3), 0.0)
    scene = backend.scene(1.0)
    assert scene is not None
    entities = decoded_update(decode_protobuf, scene_update(scene))
    plate, bowl = scene.object("plate_0"), scene.object("bowl_0")
    for goal, dish in (("top_plate_00", plate), ("bottom_bowl_11", bowl)):
        size = entities[f"goal/{goal}"]["cubes"][0]["size"]
        assert (size["x"], size["y"], size["z"]) == pytest.approx(dish.size.as_tuple())
    assert {f"object/{o.id}" for o in scene.objects} <= entities.keys()


def test_an_engaged_emergency_stop_is_written_above_the_scene_until_released(
    decode_protobuf: ProtobufDecoder,
) -> None:
    from manigraph_shared.messages import EmergencyStop

    bridge = FoxgloveBridge()
    bridge.on_message(box_scene())
    engaged = EmergencyStop(engaged=True, reason="fence open", by="ana@cell", stamp=1.0)
    (converted,) = bridge.on_message(engaged)
    assert converted.topic == SCENE_TOPIC
    entities = decoded_update(decode_protobuf, converted.message)
    (text,) = entities["estop"]["texts"]
    assert text["text"] == "ESTOP ENGAGED: fence open (by ana@cell)"
    assert text["color"]["r"] > 0.9 and text["color"]["g"] < 0.1  # red
    assert "object/block_0" in entities  # the scene is still drawn under it
    # Every later update still shows it (each update redraws everything) ...
    assert "estop" in decoded_update(decode_protobuf, bridge.on_message(box_scene(8))[0].message)
    # ... until it is released.
    released = EmergencyStop(engaged=False, reason="manigraph resume", stamp=2.0)
    (converted,) = bridge.on_message(released)
    assert "estop" not in decoded_update(decode_protobuf, converted.message)
    # A stop arrives on its key like any message the view forwards.
    assert bridge.convert(EmergencyStop.key, engaged.encode())[0].topic == SCENE_TOPIC


def test_objects_take_their_named_colour_and_goals_say_what_they_accept(
    decode_protobuf: ProtobufDecoder,
) -> None:
    scene = Scene(
        episode_id="ep-1",
        stamp=1_700_000_000.25,
        sequence=1,
        objects=[
            SceneObject(id="block_0", category=ObjectCategory.BLOCK, position=v(0.4, 0.1, 0.02),
                        size=v(0.04, 0.04, 0.04), attributes={"colour": "blue"}),
        ],
        goals=[
            SceneGoal(id="blue_bin", category=GoalCategory.BLOCK, position=v(0.3, -0.1, 0.02),
                      accepts={"colour": "blue"}),
            SceneGoal(id="big_row", category=GoalCategory.BLOCK, position=v(0.3, 0.1, 0.035),
                      accepts={"size": [0.07, 0.07, 0.07]}),
        ],
    )  # fmt: skip
    entities = decoded_update(decode_protobuf, scene_update(scene))
    block = entities["object/block_0"]
    colour = block["cubes"][0]["color"]
    assert (colour["r"], colour["g"], colour["b"]) == pytest.approx(PALETTE["blue"])
    assert block["texts"][0]["text"] == "colour blue"
    assert entities["goal/blue_bin"]["texts"][0]["text"] == "accepts colour blue"
    # A goal that accepts one size is drawn that size, and needs no words for it.
    assert entities["goal/big_row"]["cubes"][0]["size"]["x"] == pytest.approx(0.07)
    assert not entities["goal/big_row"].get("texts")


@pytest.mark.parametrize("task", ["shelf", "dishwasher"])
def test_every_fixture_is_drawn_with_its_kind_whatever_its_family(
    decode_protobuf: ProtobufDecoder, task: str
) -> None:
    from manigraph_shared.messages import EpisodeRequest
    from manigraph_sim.geometric.backend import GeometricBackend

    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, objects=4), 0.0)
    scene = backend.scene(1.0)
    assert scene is not None and scene.fixtures
    entities = decoded_update(decode_protobuf, scene_update(scene))
    for fixture in scene.fixtures:
        entity = entities[f"fixture/{fixture.id}"]
        assert {"key": "kind", "value": fixture.kind} in entity["metadata"]
        cube = entity["cubes"][0]
        assert xyz(cube["pose"]) == pytest.approx(fixture.position.as_tuple())
        assert cube["color"]["a"] < 1.0  # translucent: what stands inside shows through
        size = (cube["size"]["x"], cube["size"]["y"], cube["size"]["z"])
        if fixture.size is not None:  # a shelf's board or wall: its own box
            assert size == pytest.approx(fixture.size.as_tuple())
        else:  # a rack: a marker at its handle
            assert max(size) < 0.05
        assert entity["texts"][0]["text"].startswith(f"kind {fixture.kind}")
    assert {f"object/{o.id}" for o in scene.objects} <= entities.keys()
