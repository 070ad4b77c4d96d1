"""`manigraph export --format ros2`: the bag read back with rosbags (no ROS install) holds
every exported message with the right type, count, stamps and values."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import pytest
import yaml
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from manigraph_shared.mcap_log import LoggedMessage, read_log
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    EpisodeEvent,
    Explanation,
    JointState,
    Scene,
)
from manigraph_tools.panda_frames import BASE_FRAME, link_poses

STORE = get_typestore(Stores.ROS2_JAZZY)
EXPECTED_TYPES = {
    "/manigraph/scene_markers": "visualization_msgs/msg/MarkerArray",
    "/manigraph/joint_states": "sensor_msgs/msg/JointState",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/manigraph/camera/table/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/manigraph/camera/table/camera_info": "sensor_msgs/msg/CameraInfo",
    "/manigraph/planner/action": "std_msgs/msg/String",
    "/manigraph/planner/explanation": "std_msgs/msg/String",
    "/manigraph/world/episode": "std_msgs/msg/String",
}


def export(log: Path, out: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "manigraph_shared.cli",
            "export",
            str(log),
            "--format",
            "ros2",
            "-o",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def read_bag(bag: Path) -> dict[str, list[tuple[str, int, Any]]]:
    """Per topic: (type, bag timestamp, deserialized message), in bag order."""
    topics: dict[str, list[tuple[str, int, Any]]] = defaultdict(list)
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["storage_identifier"] == "mcap" and metadata["version"] == 9
    with Reader(bag) as reader:
        for connection, timestamp, data in reader.messages():
            assert connection.ext.serialization_format == "cdr"
            assert connection.msgdef.format.name == "MSG"  # ros2msg schemas
            message = STORE.deserialize_cdr(data, connection.msgtype)
            topics[connection.topic].append((connection.msgtype, timestamp, message))
    return topics


def stamp_of(header: Any) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def source(log: Path, message_type: type) -> list[tuple[LoggedMessage, Any]]:
    return [(item, item.decode()) for item in read_log(log, [message_type.key_pattern()])]


@pytest.fixture(scope="module")
def exported(robot_log: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("export") / "bag"
    result = export(robot_log, out)
    assert result.returncode == 0, result.stderr
    return out, json.loads(result.stdout.strip().splitlines()[-1])


def test_every_topic_has_its_standard_type_and_the_summary_counts_it(
    exported: tuple[Path, dict], robot_log: Path
) -> None:
    bag, summary = exported
    topics = read_bag(bag)
    assert {topic: entries[0][0] for topic, entries in topics.items()} == EXPECTED_TYPES
    for topic, entries in topics.items():
        assert all(msgtype == EXPECTED_TYPES[topic] for msgtype, _, _ in entries)
        assert summary["topics"][topic] == {"type": EXPECTED_TYPES[topic], "count": len(entries)}
    assert summary["truncated"] is None
    statuses = list(read_log(robot_log, ["manigraph/status/*"]))
    assert statuses and summary["skipped"] == {"manigraph/status/sim": len(statuses)}
    assert summary["messages_read"] == sum(1 for _ in read_log(robot_log))


def test_joint_states_match_the_source_to_1e_9(
    exported: tuple[Path, dict], robot_log: Path
) -> None:
    bag, _ = exported
    written = read_bag(bag)["/manigraph/joint_states"]
    recorded = source(robot_log, JointState)
    assert len(written) == len(recorded) > 0
    for (_, timestamp, ros), (item, state) in zip(written, recorded, strict=True):
        assert timestamp == item.log_time_ns
        assert abs(stamp_of(ros.header) - state.stamp) < 1e-6
        assert list(ros.name[:7]) == state.joint_names
        assert (
            max(abs(a - b) for a, b in zip(ros.position[:7], state.positions, strict=True)) <= 1e-9
        )
        assert list(ros.name[7:]) == ["panda_finger_joint1", "panda_finger_joint2"]
        assert all(abs(q - state.gripper_width / 2) <= 1e-9 for q in ros.position[7:])


def test_tf_has_every_panda_link_from_each_joint_state(
    exported: tuple[Path, dict], robot_log: Path
) -> None:
    bag, _ = exported
    written = read_bag(bag)["/tf"]
    recorded = source(robot_log, JointState)
    [(_, first_scene)] = source(robot_log, Scene)[:1]
    # The first scene comes before any joint state: it places the robot base alone.
    (_, timestamp, base), *links = written
    assert [(t.header.frame_id, t.child_frame_id) for t in base.transforms] == [
        ("world", BASE_FRAME)
    ]
    assert abs(stamp_of(base.transforms[0].header) - first_scene.stamp) < 1e-6
    assert len(links) == len(recorded) > 0
    for (_, timestamp, ros), (item, state) in zip(links, recorded, strict=True):
        assert timestamp == item.log_time_ns
        by_child = {t.child_frame_id: t for t in ros.transforms}
        assert by_child[BASE_FRAME].header.frame_id == "world"
        for child, ((x, y, z), (qx, qy, qz, qw)) in link_poses(state).items():
            t = by_child[child].transform
            assert (
                abs(t.translation.x - x) + abs(t.translation.y - y) + abs(t.translation.z - z)
                < 1e-9
            )
            rotation = (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w)
            assert max(abs(a - b) for a, b in zip(rotation, (qx, qy, qz, qw), strict=True)) < 1e-9
            assert abs(stamp_of(by_child[child].header) - state.stamp) < 1e-6


def test_scene_markers_place_every_object_and_goal(
    exported: tuple[Path, dict], robot_log: Path
) -> None:
    bag, _ = exported
    written = read_bag(bag)["/manigraph/scene_markers"]
    recorded = source(robot_log, Scene)
    assert len(written) == len(recorded) > 0
    for (_, timestamp, ros), (item, scene) in zip(written, recorded, strict=True):
        assert timestamp == item.log_time_ns
        assert ros.markers[0].action == 3  # DELETEALL first: nothing stale stays drawn
        cubes = {(m.ns, m.text): m for m in ros.markers[1:]}
        assert len(cubes) == len(scene.objects) + len(scene.goals)
        for entity, ns in [
            *((o, "objects") for o in scene.objects),
            *((g, "goals") for g in scene.goals),
        ]:
            marker = cubes[(ns, entity.id)]
            assert (
                marker.pose.position.x,
                marker.pose.position.y,
                marker.pose.position.z,
            ) == entity.position.as_tuple()
            assert marker.pose.orientation.z == entity.orientation.z
            assert marker.header.frame_id == scene.frame_id
            assert abs(stamp_of(marker.header) - scene.stamp) < 1e-6
        for obj in scene.objects:
            marker = cubes[("objects", obj.id)]
            assert (marker.scale.x, marker.scale.y, marker.scale.z) == obj.size.as_tuple()


def test_camera_frames_and_intrinsics_are_carried_byte_for_byte(
    exported: tuple[Path, dict], robot_log: Path
) -> None:
    bag, _ = exported
    topics = read_bag(bag)
    images = topics["/manigraph/camera/table/image/compressed"]
    recorded = source(robot_log, CompressedImage)
    assert len(images) == len(recorded) > 0
    for (_, timestamp, ros), (item, image) in zip(images, recorded, strict=True):
        assert timestamp == item.log_time_ns
        assert bytes(ros.data) == image.data and ros.format == "jpeg"
        assert ros.header.frame_id == "table"
        assert abs(stamp_of(ros.header) - image.stamp) < 1e-6
    [(_, _, info)] = topics["/manigraph/camera/table/camera_info"]
    [(_, source_info)] = source(robot_log, CameraInfo)
    assert list(info.k) == source_info.camera_matrix and list(info.d) == source_info.distortion
    assert (info.width, info.height, info.distortion_model) == (64, 48, "plumb_bob")


@pytest.mark.parametrize(
    ("topic", "message_type"),
    [
        ("/manigraph/planner/action", Action),
        ("/manigraph/planner/explanation", Explanation),
        ("/manigraph/world/episode", EpisodeEvent),
    ],
)
def test_decisions_are_strings_of_their_json(
    exported: tuple[Path, dict], robot_log: Path, topic: str, message_type: type
) -> None:
    bag, _ = exported
    written = read_bag(bag)[topic]
    recorded = source(robot_log, message_type)
    assert len(written) == len(recorded) > 0
    for (_, timestamp, ros), (item, message) in zip(written, recorded, strict=True):
        assert timestamp == item.log_time_ns
        assert message_type.decode(ros.data.encode()) == message
