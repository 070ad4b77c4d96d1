"""A recorded run opens in Foxglove's 3D panel: foxglove.SceneUpdate on its own channel,
decoded with the schema the file carries, matching the recorded Scene."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Explanation, Scene
from manigraph_testkit.testing import run_up
from manigraph_tools.foxglove_bridge import SCENE_TOPIC, TF_TOPIC

CHECKPOINTS = Path(__file__).resolve().parents[2] / "checkpoints"
ProtobufDecoder = Callable[[str, bytes, bytes], dict[str, Any]]

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("foxglove") / "run.mcap"
    run_up(
        "--policy",
        str(CHECKPOINTS / "sage.pt"),
        "--blocks",
        "3",
        "--episodes",
        "1",
        "--explain-decisions",
        "--record",
        str(log),
    )
    return log


def foxglove_messages(
    log: Path, topic: str, decode: ProtobufDecoder
) -> tuple[str, list[dict[str, Any]]]:
    """(schema name, decoded messages) of one channel, checking what Foxglove relies on."""
    messages = []
    schema_name = ""
    with log.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(topics=[topic]):
            assert schema is not None and schema.encoding == "protobuf"
            assert channel.message_encoding == "protobuf"
            schema_name = schema.name
            messages.append(decode(schema.name, schema.data, message.data))
    return schema_name, messages


def test_the_log_carries_scene_updates_that_match_the_recorded_scenes(
    recorded: Path, decode_protobuf: ProtobufDecoder
) -> None:
    schema, updates = foxglove_messages(recorded, SCENE_TOPIC, decode_protobuf)
    assert schema == "foxglove.SceneUpdate"
    scenes = {
        s.sequence: s for s in map(Scene.decode, (i.data for i in read_log(recorded, [Scene.key])))
    }
    actions = {Action.decode(i.data).decision_id for i in read_log(recorded, [Action.key])}
    assert len(updates) >= len(scenes) > 0
    decisions = 0
    for update in updates:
        entities = {entity["id"]: entity for entity in update["entities"]}
        sequence = int(next(iter(entities.values()))["metadata"][0]["value"])
        scene = scenes[sequence]
        for item in scene.objects:
            cube = entities[f"object/{item.id}"]["cubes"][0]
            position = cube["pose"]["position"]
            assert (position["x"], position["y"], position["z"]) == pytest.approx(
                item.position.as_tuple()
            )
        for goal in scene.goals:
            position = entities[f"goal/{goal.id}"]["cubes"][0]["pose"]["position"]
            assert (position["x"], position["y"], position["z"]) == pytest.approx(
                goal.position.as_tuple()
            )
        if "decision" in entities:
            decisions += 1
            assert entities["decision"]["arrows"][0]["shaft_length"] > 0
    assert len(actions) == 3 and decisions > 0
    assert any("explanation" in {e["id"] for e in u["entities"]} for u in updates)


def test_the_log_carries_the_robot_base_frame(
    recorded: Path, decode_protobuf: ProtobufDecoder
) -> None:
    schema, transforms = foxglove_messages(recorded, TF_TOPIC, decode_protobuf)
    assert schema == "foxglove.FrameTransforms"
    (base,) = transforms[0]["transforms"]
    assert (base["parent_frame_id"], base["child_frame_id"]) == ("world", "panda_link0")


def test_the_json_channels_are_the_contract_as_before(recorded: Path) -> None:
    topics = {item.topic for item in read_log(recorded)}
    assert {Scene.key, Action.key, Explanation.key, SCENE_TOPIC, TF_TOPIC} <= topics
    for item in read_log(recorded, ["manigraph/**"]):
        assert item.decode().encode() == item.data  # each sample byte for byte as published


def test_a_dishwasher_run_is_logged_whole_with_its_scene_updates(
    tmp_path: Path, decode_protobuf: ProtobufDecoder
) -> None:
    log = tmp_path / "dishwasher.mcap"
    run_up(
        "--task", "dishwasher", "--objects", "2", "--policy", "dishwasher-top-bottom",
        "--episodes", "1", "--record", str(log),
    )  # fmt: skip
    actions = [Action.decode(i.data) for i in read_log(log, [Action.key])]
    assert len(actions) >= 4  # top rack out, a bowl, the rack in, ...: every decision is there
    _, updates = foxglove_messages(log, SCENE_TOPIC, decode_protobuf)
    slots = {e["id"] for u in updates for e in u["entities"] if e["id"].startswith("goal/")}
    assert "goal/top_bowl_00" in slots and "goal/bottom_plate_00" in slots
